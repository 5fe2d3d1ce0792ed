//! I2C1, the STM32F446's I2C interface in its v1 form (RM0390 §24), as a bus master: its
//! registers (CR1, CR2, OAR1, OAR2, DR, SR1, SR2, CCR, TRISE, FLTR), the master transmitter
//! and receiver's event sequences (§24.3.3), the bytes' timing on SCL, the error flags, the
//! event and error interrupt lines (IRQ 31 and 32) and the DMA requests (§24.3.7).
//!
//! The bus's other end is an [`I2cTarget`]: a device that answers START with its address,
//! takes written bytes and gives read bytes, byte by byte as on the wires (the virtual
//! MLX90640 attaches through an adapter that turns a byte stream into its register
//! transactions: a two-byte write sets the register pointer, reads return the words from
//! there big-endian). The harness can also make the bus misbehave: hold SDA low
//! ([`I2c::hold_sda_low`]), make the next byte lose arbitration to another master
//! ([`I2c::lose_arbitration_at_next_byte`]) or put a misplaced START/STOP on the bus
//! ([`I2c::misplaced_start_or_stop`]).
//!
//! Timing: the SCL period is what CCR gives with PCLK1 (standard mode 2·CCR, fast mode 3·CCR
//! with DUTY=0 or 25·CCR with DUTY=1 cycles of PCLK1; lines ideal, so TRISE and FLTR do not
//! change it). A byte with its acknowledge takes 9 SCL periods; a START (or repeated START)
//! condition and a STOP condition take one SCL period each. At the board's 45 MHz and CCR 37
//! (fast mode, DUTY=0) a period is 111 PCLK1 cycles (2.467 µs, 405 kHz) and a byte 22.2 µs.
//!
//! Modelled as the manual says: the master transmitter (EV5, EV6, EV8_1, EV8, EV8_2) and
//! receiver (EV5, EV6, EV7, EV7_1; one byte: ACK=0 before clearing ADDR; two bytes: POS;
//! N bytes: ACK cleared at BTF; DMA: LAST makes the byte after EOT−1 a NACK), the clearing
//! sequences (SB: SR1 read then DR write; ADDR: SR1 read then SR2 read; BTF: SR1 read then a
//! DR access), clock stretching (the master waits with SCL low while SB, ADDR or BTF is set:
//! a received byte waits in the shift register with BTF and nothing is lost, so OVR cannot
//! happen in master mode, as the manual says of stretching), the 10-bit address header
//! (ADD10), AF on a NACK of the address or of a written byte, ARLO (the interface drops to
//! slave mode: MSL cleared, the other master keeps the bus busy for a byte and its STOP),
//! BERR, BUSY from the lines (held by SDA low, cleared only by a STOP seen on the bus,
//! SWRST or PE=0: after SDA is released a START stays pending until then — the errata's
//! "start cannot be generated" lock-up the board recovers from with SWRST), SWRST and PE=0.
//!
//! Not modelled (the board's driver never uses them): slave mode (OAR1/OAR2/ENGC are stored,
//! but nothing ever addresses this interface, so GENCALL, DUALF, STOPF and OVR stay 0), SMBus
//! (SMBUS, SMBTYPE, ENARP, ALERT are stored; TIMEOUT, SMBALERT, SMBDEFAULT, SMBHOST stay 0),
//! PEC (ENPEC and PEC are stored; no PEC byte is sent or checked, SR2.PEC reads 0, PECERR
//! stays 0). FREQ is stored; the timing uses PCLK1 itself (the board programs FREQ to match).
//! Clearing PE aborts a transfer at once (the manual lets the byte in progress end).

use super::{Clocks, DmaRequests, IrqLines, Peripheral, Size, Time};

/// The base address of I2C1's register window.
pub const I2C1_BASE: u32 = 0x4000_5400;
/// I2C1's event interrupt (NVIC position).
pub const I2C1_EV_IRQ: u16 = 31;
/// I2C1's error interrupt (NVIC position).
pub const I2C1_ER_IRQ: u16 = 32;

/// A device on the bus, seen byte by byte as the master drives it.
///
/// An adapter to a register-transaction device (the virtual MLX90640's
/// `transaction(address, &mut [Operation])`) collects written bytes after `start(a, false)`
/// and hands them over at the next `start` or `stop`; after `start(a, true)` it fetches the
/// words to send from the pointer the preceding write set.
pub trait I2cTarget {
    /// A START (or repeated START) followed by the address byte: `address` the 7-bit address,
    /// `read` the R/W bit. Returns whether the device acknowledges (a device that is not at
    /// `address` does not).
    fn start(&mut self, address: u8, read: bool) -> bool;
    /// A byte the master wrote; returns whether the device acknowledges it.
    fn write(&mut self, byte: u8) -> bool;
    /// The next byte the device sends; `ack` is the master's answer after it (false: NACK,
    /// the device stops sending).
    fn read(&mut self, ack: bool) -> u8;
    /// A STOP condition (the transaction's end).
    fn stop(&mut self);
}

/// CR1's bits (RM0390 §24.6.1).
pub mod cr1 {
    /// Peripheral enable.
    pub const PE: u16 = 1 << 0;
    /// SMBus mode (stored, not modelled).
    pub const SMBUS: u16 = 1 << 1;
    /// SMBus type (stored, not modelled).
    pub const SMBTYPE: u16 = 1 << 3;
    /// ARP enable (stored, not modelled).
    pub const ENARP: u16 = 1 << 4;
    /// PEC enable (stored, not modelled).
    pub const ENPEC: u16 = 1 << 5;
    /// General call enable (slave mode: stored).
    pub const ENGC: u16 = 1 << 6;
    /// Clock stretching disable (slave mode: stored).
    pub const NOSTRETCH: u16 = 1 << 7;
    /// START generation.
    pub const START: u16 = 1 << 8;
    /// STOP generation.
    pub const STOP: u16 = 1 << 9;
    /// Acknowledge enable.
    pub const ACK: u16 = 1 << 10;
    /// ACK position (1: ACK applies to the next byte).
    pub const POS: u16 = 1 << 11;
    /// Packet error checking (stored, not modelled).
    pub const PEC: u16 = 1 << 12;
    /// SMBus alert (stored, not modelled).
    pub const ALERT: u16 = 1 << 13;
    /// Software reset.
    pub const SWRST: u16 = 1 << 15;
    /// The bits that exist.
    pub const MASK: u16 = 0xBFFB;
}

/// CR2's bits (RM0390 §24.6.2).
pub mod cr2 {
    /// Peripheral clock frequency, MHz (6 bits).
    pub const FREQ: u16 = 0x3F;
    /// Error interrupt enable.
    pub const ITERREN: u16 = 1 << 8;
    /// Event interrupt enable.
    pub const ITEVTEN: u16 = 1 << 9;
    /// Buffer interrupt enable (TXE/RXNE on the event line).
    pub const ITBUFEN: u16 = 1 << 10;
    /// DMA requests enable.
    pub const DMAEN: u16 = 1 << 11;
    /// DMA last transfer (NACK the byte after EOT−1).
    pub const LAST: u16 = 1 << 12;
    /// The bits that exist.
    pub const MASK: u16 = 0x1F3F;
}

/// SR1's bits (RM0390 §24.6.6).
pub mod sr1 {
    /// Start bit (master mode).
    pub const SB: u16 = 1 << 0;
    /// Address sent (master) and acknowledged.
    pub const ADDR: u16 = 1 << 1;
    /// Byte transfer finished.
    pub const BTF: u16 = 1 << 2;
    /// 10-bit header sent.
    pub const ADD10: u16 = 1 << 3;
    /// Stop detected (slave mode: never set here).
    pub const STOPF: u16 = 1 << 4;
    /// Data register not empty (receivers).
    pub const RXNE: u16 = 1 << 6;
    /// Data register empty (transmitters).
    pub const TXE: u16 = 1 << 7;
    /// Bus error.
    pub const BERR: u16 = 1 << 8;
    /// Arbitration lost.
    pub const ARLO: u16 = 1 << 9;
    /// Acknowledge failure.
    pub const AF: u16 = 1 << 10;
    /// Overrun/underrun.
    pub const OVR: u16 = 1 << 11;
    /// PEC error in reception (never set here).
    pub const PECERR: u16 = 1 << 12;
    /// Timeout (SMBus; never set here).
    pub const TIMEOUT: u16 = 1 << 14;
    /// SMBus alert (never set here).
    pub const SMBALERT: u16 = 1 << 15;
    /// The error flags (rc_w0: software clears them by writing 0).
    pub const ERRORS: u16 = BERR | ARLO | AF | OVR | PECERR | TIMEOUT | SMBALERT;
}

/// SR2's bits (RM0390 §24.6.7).
pub mod sr2 {
    /// Master mode.
    pub const MSL: u16 = 1 << 0;
    /// Bus busy.
    pub const BUSY: u16 = 1 << 1;
    /// Transmitter (from the address byte's R/W bit).
    pub const TRA: u16 = 1 << 2;
    /// General call address received (slave mode: never set here).
    pub const GENCALL: u16 = 1 << 4;
}

/// CCR's bits (RM0390 §24.6.8).
pub mod ccr {
    /// The clock control value (12 bits).
    pub const CCR: u16 = 0x0FFF;
    /// Fast mode duty cycle (1: 16/9).
    pub const DUTY: u16 = 1 << 14;
    /// Fast mode.
    pub const FS: u16 = 1 << 15;
}

/// The bus activity in progress (it ends at a time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Op {
    /// A START or repeated START condition.
    Start,
    /// The address byte (7-bit address and R/W, or a 10-bit header).
    Address(u8),
    /// The second byte of a 10-bit address.
    Address10(u8),
    /// A data byte the master transmits.
    Tx(u8),
    /// A data byte the master receives.
    Rx,
    /// A STOP condition.
    Stop,
    /// After lost arbitration: the other master's transfer, then its STOP.
    OtherMaster,
}

/// I2C1 (v1) as a master, with the device on its bus.
pub struct I2c {
    cr1: u16,
    cr2: u16,
    oar1: u16,
    oar2: u16,
    ccr: u16,
    trise: u16,
    fltr: u16,
    sr1: u16,
    sr2: u16,
    /// DR's content (the last byte written or received).
    dr: u8,
    /// A byte written to DR not yet moved to the shift register (TXE=0).
    dr_full: bool,
    /// A received byte waiting in the shift register (BTF in reception).
    shift_rx: Option<u8>,
    /// SR1 was read while the flag was set (the first half of its clearing sequence).
    sb_seen: bool,
    addr_seen: bool,
    btf_seen: bool,
    add10_seen: bool,
    /// Receiving: the next byte is clocked in when the shift register is free.
    rx_active: bool,
    /// With POS=1: the ACK value latched for the byte being received.
    pos_ack: bool,
    /// The DMA's EOT−1 was signalled (with LAST: NACK the byte after it).
    eot_1: bool,
    /// The activity in progress and its end.
    op: Option<(Time, Op)>,
    now: Time,
    clocks: Clocks,
    target: Option<Box<dyn I2cTarget>>,
    sda_low: bool,
    lose_arbitration: bool,
}

impl core::fmt::Debug for I2c {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("I2c")
            .field("cr1", &self.cr1)
            .field("cr2", &self.cr2)
            .field("sr1", &self.sr1)
            .field("sr2", &self.sr2)
            .field("op", &self.op)
            .finish_non_exhaustive()
    }
}

impl Default for I2c {
    fn default() -> Self {
        Self::new()
    }
}

impl I2c {
    /// I2C1 after reset (TRISE 2, everything else 0), no device on the bus, clocks at reset.
    pub fn new() -> Self {
        I2c {
            cr1: 0,
            cr2: 0,
            oar1: 0,
            oar2: 0,
            ccr: 0,
            trise: 2,
            fltr: 0,
            sr1: 0,
            sr2: 0,
            dr: 0,
            dr_full: false,
            shift_rx: None,
            sb_seen: false,
            addr_seen: false,
            btf_seen: false,
            add10_seen: false,
            rx_active: false,
            pos_ack: false,
            eot_1: false,
            op: None,
            now: 0,
            clocks: Clocks::RESET,
            target: None,
            sda_low: false,
            lose_arbitration: false,
        }
    }

    /// Put `target` on the bus (replacing any other).
    pub fn attach(&mut self, target: Box<dyn I2cTarget>) {
        self.target = Some(target);
    }

    /// Take the device off the bus (addresses are then not acknowledged).
    pub fn detach(&mut self) -> Option<Box<dyn I2cTarget>> {
        self.target.take()
    }

    /// Harness: hold SDA low (a device stuck mid-byte) or release it. While it is held BUSY
    /// is set and a START is never generated; a byte in progress loses arbitration. Releasing
    /// it leaves BUSY set until a STOP is seen on the bus ([`I2c::stop_on_bus`]), SWRST or
    /// PE=0.
    pub fn hold_sda_low(&mut self, low: bool) {
        self.sda_low = low;
        if low && self.cr1 & cr1::PE != 0 {
            self.sr2 |= sr2::BUSY;
            if let Some((_, Op::Start)) = self.op {
                // The START cannot be generated: it stays pending.
                self.op = None;
                self.sr2 &= !sr2::MSL;
            }
        }
    }

    /// Harness: a STOP condition on the lines made by someone else (another master, or a
    /// recovery that toggles the lines while the interface watches them): BUSY clears and a
    /// pending START goes ahead.
    pub fn stop_on_bus(&mut self) {
        if self.sda_low || self.sr2 & sr2::MSL != 0 {
            return;
        }
        self.sr2 &= !sr2::BUSY;
        self.cr1 &= !cr1::STOP;
        if self.cr1 & cr1::START != 0 {
            self.try_start();
        }
    }

    /// The RCC's reset of I2C1 (APB1RSTR I2C1RST, pulsed by the driver's `new`): every
    /// register to its reset value; the device on the bus and the lines' state stay.
    pub fn rcc_reset(&mut self) {
        self.reset();
    }

    /// Harness: the next address or data byte this master sends loses arbitration (another
    /// master drives a 0 where it sends a 1).
    pub fn lose_arbitration_at_next_byte(&mut self) {
        self.lose_arbitration = true;
    }

    /// Harness: a misplaced START or STOP appears on the bus during a transfer: BERR. The
    /// master goes on with its transfer (§24.3.4: the hardware does not release the lines).
    pub fn misplaced_start_or_stop(&mut self) {
        if self.cr1 & cr1::PE != 0 && self.sr2 & sr2::BUSY != 0 {
            self.sr1 |= sr1::BERR;
        }
    }

    /// The DMA stream reading DR (I2C1_RX) has moved its last-but-one item (NDTR went to 1,
    /// the DMA's EOT−1): with LAST and DMAEN, the byte received after it is NACKed.
    pub fn dma_eot_1(&mut self) {
        self.eot_1 = true;
    }

    /// The DMA requests now: TX while DMAEN and TXE (transmitting), RX while DMAEN and RXNE.
    pub fn requests(&self) -> DmaRequests {
        let dma = self.cr2 & cr2::DMAEN != 0;
        DmaRequests {
            rx: dma && self.sr1 & sr1::RXNE != 0,
            tx: dma && self.sr1 & sr1::TXE != 0 && self.sr2 & sr2::TRA != 0,
        }
    }

    /// PCLK1 cycles of one SCL period.
    fn scl_cycles(&self) -> u64 {
        let c = u64::from((self.ccr & ccr::CCR).max(1));
        match (self.ccr & ccr::FS != 0, self.ccr & ccr::DUTY != 0) {
            (false, _) => 2 * c,
            (true, false) => 3 * c,
            (true, true) => 25 * c,
        }
    }

    /// The time `periods` SCL periods from now.
    fn after(&self, periods: u64) -> Time {
        self.now + Clocks::time_of(periods * self.scl_cycles(), self.clocks.pclk1_hz)
    }

    fn schedule(&mut self, periods: u64, op: Op) {
        self.op = Some((self.after(periods), op));
    }

    fn master(&self) -> bool {
        self.sr2 & sr2::MSL != 0
    }

    /// Back to the reset state (SWRST, or power-up); the harness's bus state stays.
    fn reset(&mut self) {
        if self.master() {
            if let Some(t) = self.target.as_mut() {
                t.stop();
            }
        }
        let target = self.target.take();
        let (now, clocks, sda, lose) = (self.now, self.clocks, self.sda_low, self.lose_arbitration);
        *self = I2c::new();
        self.target = target;
        self.now = now;
        self.clocks = clocks;
        self.sda_low = sda;
        self.lose_arbitration = lose;
    }

    /// PE cleared: the interface lets go of the bus, its flags clear.
    fn disable(&mut self) {
        if self.master() {
            if let Some(t) = self.target.as_mut() {
                t.stop();
            }
        }
        self.op = None;
        self.sr1 = 0;
        self.sr2 = 0;
        self.cr1 &= !(cr1::START | cr1::STOP | cr1::ACK);
        self.dr_full = false;
        self.shift_rx = None;
        self.rx_active = false;
        self.eot_1 = false;
        self.sb_seen = false;
        self.addr_seen = false;
        self.btf_seen = false;
        self.add10_seen = false;
    }

    /// A START was asked for: generate it if the bus allows.
    fn try_start(&mut self) {
        if self.cr1 & cr1::PE == 0 || self.op.is_some() || self.sda_low {
            // Pending: after the byte in progress, or when the bus frees.
            return;
        }
        if self.master() {
            // A repeated START (the master holds SCL low between bytes).
            self.schedule(1, Op::Start);
        } else if self.sr2 & sr2::BUSY == 0 {
            self.sr2 |= sr2::BUSY;
            self.schedule(1, Op::Start);
        }
    }

    /// A STOP was asked for: generate it now if no byte is in progress (else at its end).
    fn try_stop(&mut self) {
        if self.cr1 & cr1::PE != 0 && !self.master() && self.sr2 & sr2::BUSY == 0 {
            // Slave mode, bus idle: nothing to release; the bit clears (as at a STOP seen).
            self.cr1 &= !cr1::STOP;
            return;
        }
        if self.cr1 & cr1::PE == 0 || self.op.is_some() || !self.master() {
            // In slave mode on a busy bus the bit clears at the STOP the bus sees.
            return;
        }
        self.schedule(1, Op::Stop);
    }

    /// After a byte or an address: a pending STOP or repeated START goes first.
    fn stop_or_restart_pending(&mut self) -> bool {
        if self.cr1 & cr1::STOP != 0 {
            self.schedule(1, Op::Stop);
            true
        } else if self.cr1 & cr1::START != 0 {
            self.schedule(1, Op::Start);
            true
        } else {
            false
        }
    }

    /// Lost arbitration: back to slave mode, the other master keeps the bus for a byte.
    fn arbitration_lost(&mut self) {
        self.lose_arbitration = false;
        self.sr1 |= sr1::ARLO;
        self.sr1 &= !(sr1::TXE | sr1::BTF);
        self.sr2 &= !(sr2::MSL | sr2::TRA);
        self.rx_active = false;
        self.dr_full = false;
        if let Some(t) = self.target.as_mut() {
            t.stop();
        }
        if self.sda_low {
            self.op = None;
        } else {
            self.schedule(9, Op::OtherMaster);
        }
    }

    /// Whether the byte being received now is acknowledged.
    fn ack_now(&mut self) -> bool {
        let ack_bit = self.cr1 & cr1::ACK != 0;
        let mut ack = if self.cr1 & cr1::POS != 0 {
            core::mem::replace(&mut self.pos_ack, ack_bit)
        } else {
            ack_bit
        };
        if self.cr2 & (cr2::DMAEN | cr2::LAST) == cr2::DMAEN | cr2::LAST && self.eot_1 {
            ack = false;
        }
        if self.cr1 & cr1::STOP != 0 {
            // A STOP asked for during reception ends it: the byte is the last one.
            ack = false;
        }
        ack
    }

    fn start_rx(&mut self) {
        if self.rx_active && self.op.is_none() && self.shift_rx.is_none() {
            self.schedule(9, Op::Rx);
        }
    }

    /// The activity `op` has ended (at `self.now`).
    fn finish(&mut self, op: Op) {
        let tx_op = matches!(op, Op::Address(_) | Op::Address10(_) | Op::Tx(_));
        if tx_op && (self.lose_arbitration || self.sda_low) {
            self.arbitration_lost();
            return;
        }
        match op {
            Op::Start => {
                if self.sda_low {
                    return;
                }
                self.cr1 &= !cr1::START;
                self.sr1 |= sr1::SB;
                self.sr1 &= !(sr1::TXE | sr1::BTF);
                self.sr2 |= sr2::MSL | sr2::BUSY;
                self.rx_active = false;
                self.eot_1 = false;
                self.dr_full = false;
                if self.cr1 & cr1::STOP != 0 {
                    self.schedule(1, Op::Stop);
                }
            }
            Op::Address(byte) => {
                let header = byte & 0xF9 == 0xF0 && byte & 1 == 0;
                let read = byte & 1 != 0;
                let ack = match self.target.as_mut() {
                    Some(t) => t.start(byte >> 1, read),
                    None => false,
                };
                if !ack {
                    self.sr1 |= sr1::AF;
                } else if header {
                    self.sr1 |= sr1::ADD10;
                } else {
                    self.address_acknowledged(read);
                }
                if !ack || !header {
                    self.stop_or_restart_pending();
                }
            }
            Op::Address10(byte) => {
                let ack = self.target.as_mut().is_some_and(|t| t.write(byte));
                if ack {
                    self.address_acknowledged(false);
                } else {
                    self.sr1 |= sr1::AF;
                }
                self.stop_or_restart_pending();
            }
            Op::Tx(byte) => {
                let ack = self.target.as_mut().is_some_and(|t| t.write(byte));
                if !ack {
                    self.sr1 |= sr1::AF;
                    self.stop_or_restart_pending();
                } else if self.stop_or_restart_pending() {
                } else if self.dr_full {
                    // EV8: the next byte moves to the shift register, DR is empty again.
                    self.dr_full = false;
                    self.sr1 |= sr1::TXE;
                    self.schedule(9, Op::Tx(self.dr));
                } else {
                    // EV8_2: both empty, SCL stretched.
                    self.sr1 |= sr1::BTF;
                }
            }
            Op::Rx => {
                let ack = self.ack_now();
                let byte = self.target.as_mut().map_or(0xFF, |t| t.read(ack));
                if self.sr1 & sr1::RXNE == 0 {
                    self.dr = byte;
                    self.sr1 |= sr1::RXNE;
                } else {
                    self.shift_rx = Some(byte);
                    self.sr1 |= sr1::BTF;
                }
                if !ack {
                    self.rx_active = false;
                }
                if !self.stop_or_restart_pending() {
                    self.start_rx();
                }
            }
            Op::Stop => {
                self.cr1 &= !cr1::STOP;
                self.sr1 &= !(sr1::TXE | sr1::BTF);
                self.sr2 &= !(sr2::MSL | sr2::BUSY | sr2::TRA);
                self.rx_active = false;
                self.eot_1 = false;
                self.dr_full = false;
                if let Some(t) = self.target.as_mut() {
                    t.stop();
                }
                if self.sda_low {
                    self.sr2 |= sr2::BUSY;
                } else if self.cr1 & cr1::START != 0 {
                    self.try_start();
                }
            }
            Op::OtherMaster => {
                self.sr2 &= !sr2::BUSY;
                self.cr1 &= !cr1::STOP;
                if self.cr1 & cr1::START != 0 {
                    self.try_start();
                }
            }
        }
    }

    /// EV6: the address was acknowledged; SCL stays low until ADDR is cleared.
    fn address_acknowledged(&mut self, read: bool) {
        self.sr1 |= sr1::ADDR;
        if read {
            self.sr2 &= !sr2::TRA;
        } else {
            self.sr2 |= sr2::TRA;
        }
        self.pos_ack = self.cr1 & cr1::ACK != 0;
    }

    /// ADDR cleared: a transmitter asks for its first byte (EV8_1), a receiver starts
    /// clocking in the first one.
    fn after_addr(&mut self) {
        if self.sr2 & sr2::TRA != 0 {
            self.sr1 |= sr1::TXE;
        } else {
            self.rx_active = true;
            if !self.stop_or_restart_pending() {
                self.start_rx();
            }
        }
    }

    fn write_dr(&mut self, byte: u8) {
        self.dr = byte;
        if self.cr1 & cr1::PE == 0 {
            return;
        }
        if self.sr1 & sr1::BTF != 0 && self.btf_seen {
            self.sr1 &= !sr1::BTF;
        }
        self.btf_seen = false;
        if self.sr1 & sr1::SB != 0 {
            if self.sb_seen {
                // EV5 cleared: the address byte goes out.
                self.sr1 &= !sr1::SB;
                self.sb_seen = false;
                self.schedule(9, Op::Address(byte));
            }
            return;
        }
        if self.sr1 & sr1::ADD10 != 0 {
            if self.add10_seen {
                self.sr1 &= !sr1::ADD10;
                self.add10_seen = false;
                self.schedule(9, Op::Address10(byte));
            }
            return;
        }
        if self.master() && self.sr2 & sr2::TRA != 0 && self.sr1 & sr1::ADDR == 0 {
            let stalled = self.op.is_none() && self.sr1 & sr1::AF == 0;
            if stalled && self.cr1 & (cr1::STOP | cr1::START) == 0 {
                // The shift register is free: the byte goes out now, DR stays empty.
                self.sr1 |= sr1::TXE;
                self.sr1 &= !sr1::BTF;
                self.schedule(9, Op::Tx(byte));
            } else {
                self.dr_full = true;
                self.sr1 &= !sr1::TXE;
            }
        }
    }

    fn read_dr(&mut self) -> u8 {
        let value = self.dr;
        if self.sr1 & sr1::BTF != 0 && self.btf_seen {
            self.sr1 &= !sr1::BTF;
        }
        self.btf_seen = false;
        if self.sr1 & sr1::RXNE != 0 {
            self.sr1 &= !sr1::RXNE;
            if let Some(b) = self.shift_rx.take() {
                // The byte waiting in the shift register moves to DR; SCL is released.
                self.dr = b;
                self.sr1 |= sr1::RXNE;
                self.sr1 &= !sr1::BTF;
                if self.master() && self.op.is_none() && !self.stop_or_restart_pending() {
                    self.start_rx();
                }
            }
        }
        value
    }

    fn write_cr1(&mut self, value: u16) {
        let value = value & cr1::MASK;
        if value & cr1::SWRST != 0 {
            self.reset();
            self.cr1 = cr1::SWRST;
            return;
        }
        // Leaving SWRST needs nothing more: the registers were held at their reset values.
        let was = self.cr1;
        self.cr1 = value;
        if value & cr1::PE == 0 {
            if was & cr1::PE != 0 || self.sr2 != 0 {
                self.disable();
            }
            self.cr1 &= !(cr1::START | cr1::STOP | cr1::ACK);
            return;
        }
        if was & cr1::PE == 0 && self.sda_low {
            self.sr2 |= sr2::BUSY;
        }
        if value & cr1::STOP != 0 {
            self.try_stop();
        }
        if value & cr1::START != 0 && self.cr1 & cr1::STOP == 0 {
            self.try_start();
        }
    }

    fn read_word(&mut self, offset: u32) -> u32 {
        u32::from(match offset {
            0x00 => self.cr1,
            0x04 => self.cr2,
            0x08 => self.oar1,
            0x0C => self.oar2,
            0x10 => u16::from(self.read_dr()),
            0x14 => {
                self.sb_seen |= self.sr1 & sr1::SB != 0;
                self.addr_seen |= self.sr1 & sr1::ADDR != 0;
                self.btf_seen |= self.sr1 & sr1::BTF != 0;
                self.add10_seen |= self.sr1 & sr1::ADD10 != 0;
                self.sr1
            }
            0x18 => {
                let v = self.sr2;
                if self.sr1 & sr1::ADDR != 0 && self.addr_seen {
                    // EV6 cleared.
                    self.sr1 &= !sr1::ADDR;
                    self.addr_seen = false;
                    self.after_addr();
                }
                v
            }
            0x1C => self.ccr,
            0x20 => self.trise,
            0x24 => self.fltr,
            _ => 0,
        })
    }

    /// The register's value without side effects (for merging a narrow write).
    fn peek(&self, offset: u32) -> u16 {
        match offset {
            0x00 => self.cr1,
            0x04 => self.cr2,
            0x08 => self.oar1,
            0x0C => self.oar2,
            0x10 => u16::from(self.dr),
            0x14 => self.sr1,
            0x18 => self.sr2,
            0x1C => self.ccr,
            0x20 => self.trise,
            0x24 => self.fltr,
            _ => 0,
        }
    }
}

impl Peripheral for I2c {
    fn name(&self) -> &'static str {
        "I2C1"
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        // Registers are 16 bits wide in the low half of each word.
        let word = offset & !3;
        if offset & 3 >= 2 {
            return 0;
        }
        super::lanes(self.read_word(word), offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        let word = offset & !3;
        let value = super::merge(u32::from(self.peek(word)), offset, size, value) as u16;
        if self.cr1 & cr1::SWRST != 0 && word != 0x00 {
            // Under reset: only CR1 (to release SWRST) is written.
            return;
        }
        match word {
            0x00 => self.write_cr1(value),
            0x04 => self.cr2 = value & cr2::MASK,
            0x08 => self.oar1 = value & 0xC3FF,
            0x0C => self.oar2 = value & 0x00FF,
            0x10 => self.write_dr(value as u8),
            // rc_w0: writing 0 clears an error flag, 1 leaves it; the others are read-only.
            0x14 => self.sr1 &= value | !sr1::ERRORS,
            0x1C => self.ccr = value & 0xCFFF,
            0x20 => self.trise = value & 0x3F,
            0x24 => self.fltr = value & 0x1F,
            _ => {}
        }
    }

    fn advance(&mut self, now: Time, clocks: &Clocks) {
        self.clocks = *clocks;
        while let Some((end, op)) = self.op {
            if end > now {
                break;
            }
            self.now = end;
            self.op = None;
            self.finish(op);
        }
        self.now = self.now.max(now);
    }

    fn next_event(&self, now: Time, _clocks: &Clocks) -> Option<Time> {
        self.op.map(|(end, _)| end.max(now + 1))
    }
}

impl IrqLines for I2c {
    fn irqs(&self, line: &mut dyn FnMut(u16, bool)) {
        let s = self.sr1;
        let events = sr1::SB | sr1::ADDR | sr1::ADD10 | sr1::STOPF | sr1::BTF;
        let buffer = sr1::TXE | sr1::RXNE;
        let ev = self.cr2 & cr2::ITEVTEN != 0
            && (s & events != 0 || (self.cr2 & cr2::ITBUFEN != 0 && s & buffer != 0));
        let er = self.cr2 & cr2::ITERREN != 0 && s & sr1::ERRORS != 0;
        line(I2C1_EV_IRQ, ev);
        line(I2C1_ER_IRQ, er);
    }
}

#[cfg(test)]
mod tests {
    use super::super::dma::{BusFault, Controller, Dma, DmaBus, Serviced, cr as dcr};
    use super::*;
    use std::cell::RefCell;
    use std::rc::Rc;

    /// A device with 16-bit registers at 16-bit addresses, as the MLX90640: a write of two
    /// bytes sets the pointer, two more write a word; reads return words big-endian from the
    /// pointer on.
    #[derive(Default)]
    struct Regs {
        address: u8,
        words: std::collections::BTreeMap<u16, u16>,
        written: Vec<u8>,
        pointer: u16,
        read_high: bool,
        log: Vec<String>,
        nack_data: bool,
    }

    #[derive(Clone, Default)]
    struct Dev(Rc<RefCell<Regs>>);

    impl I2cTarget for Dev {
        fn start(&mut self, address: u8, read: bool) -> bool {
            let mut d = self.0.borrow_mut();
            d.log
                .push(format!("S{address:02x}{}", if read { 'r' } else { 'w' }));
            d.written.clear();
            d.read_high = true;
            address == d.address
        }
        fn write(&mut self, byte: u8) -> bool {
            let mut d = self.0.borrow_mut();
            d.log.push(format!("W{byte:02x}"));
            d.written.push(byte);
            if d.written.len() == 2 {
                d.pointer = u16::from_be_bytes([d.written[0], d.written[1]]);
            }
            !d.nack_data
        }
        fn read(&mut self, ack: bool) -> u8 {
            let mut d = self.0.borrow_mut();
            let w = d.words.get(&d.pointer).copied().unwrap_or(0);
            let b = if d.read_high {
                (w >> 8) as u8
            } else {
                d.pointer = d.pointer.wrapping_add(1);
                w as u8
            };
            d.read_high = !d.read_high;
            d.log
                .push(format!("R{b:02x}{}", if ack { "a" } else { "n" }));
            b
        }
        fn stop(&mut self) {
            self.0.borrow_mut().log.push("P".into());
        }
    }

    const CR1: u32 = 0x00;
    const CR2: u32 = 0x04;
    const DR: u32 = 0x10;
    const SR1: u32 = 0x14;
    const SR2: u32 = 0x18;
    const CCR: u32 = 0x1C;
    const TRISE: u32 = 0x20;

    const CLOCKS: Clocks = Clocks {
        sysclk_hz: 180_000_000,
        hclk_hz: 180_000_000,
        pclk1_hz: 45_000_000,
        pclk2_hz: 90_000_000,
        tim_apb1_hz: 90_000_000,
        tim_apb2_hz: 180_000_000,
        lsi_hz: 32_000,
    };
    /// One SCL period at 45 MHz with CCR 37 in fast mode: 111 PCLK1 cycles of 16 ticks.
    const SCL: Time = 111 * 16;

    /// The chip around the I2C: RAM and I2C1's DR for DMA1, the time, the wiring of
    /// DMA1 stream 6 (TX) and 0 (RX) on channel 1.
    struct Rig {
        i2c: I2c,
        dma: Dma,
        ram: Vec<u8>,
        now: Time,
        dev: Dev,
    }

    struct Bus<'a> {
        i2c: &'a mut I2c,
        ram: &'a mut Vec<u8>,
    }

    const RAM: u32 = 0x2000_0000;

    impl DmaBus for Bus<'_> {
        fn read(&mut self, address: u32, size: Size) -> Result<u32, BusFault> {
            match address {
                a if (I2C1_BASE..I2C1_BASE + 0x400).contains(&a) => {
                    Ok(self.i2c.read(a - I2C1_BASE, size))
                }
                a if (RAM..RAM + self.ram.len() as u32).contains(&a) => {
                    assert_eq!(size, Size::Byte);
                    Ok(u32::from(self.ram[(a - RAM) as usize]))
                }
                _ => Err(BusFault),
            }
        }
        fn write(&mut self, address: u32, size: Size, value: u32) -> Result<(), BusFault> {
            match address {
                a if (I2C1_BASE..I2C1_BASE + 0x400).contains(&a) => {
                    self.i2c.write(a - I2C1_BASE, size, value);
                    Ok(())
                }
                a if (RAM..RAM + self.ram.len() as u32).contains(&a) => {
                    self.ram[(a - RAM) as usize] = value as u8;
                    Ok(())
                }
                _ => Err(BusFault),
            }
        }
    }

    impl Rig {
        fn new() -> Self {
            let dev = Dev::default();
            dev.0.borrow_mut().address = 0x33;
            let mut i2c = I2c::new();
            i2c.attach(Box::new(dev.clone()));
            i2c.advance(0, &CLOCKS);
            Rig {
                i2c,
                dma: Dma::new(Controller::Dma1),
                ram: vec![0; 256],
                now: 0,
                dev,
            }
        }

        fn rd(&mut self, reg: u32) -> u16 {
            self.i2c.read(reg, Size::Word) as u16
        }

        fn wr(&mut self, reg: u32, v: u16) {
            self.i2c.write(reg, Size::Word, u32::from(v));
        }

        fn modify(&mut self, reg: u32, f: impl FnOnce(u16) -> u16) {
            let v = self.i2c.peek(reg);
            self.wr(reg, f(v));
        }

        /// embassy's `init`: PE off, SWRST on and off, FREQ, CCR, TRISE, PE on.
        fn init(&mut self) {
            self.modify(CR1, |v| v & !cr1::PE);
            self.modify(CR1, |v| v | cr1::SWRST);
            self.modify(CR1, |v| v & !cr1::SWRST);
            self.modify(CR2, |v| (v & !cr2::FREQ) | 45);
            // 45 MHz / (400 kHz · 3) = 37, fast mode, DUTY=0; TRISE 45·300/1000 + 1 = 14.
            self.modify(CCR, |_| ccr::FS | 37);
            self.modify(TRISE, |_| 14);
            self.modify(CR1, |v| v | cr1::PE);
        }

        /// The DMA requests go to their streams while they are up (the chip's wiring).
        fn run_dma(&mut self) {
            loop {
                let req = self.i2c.requests();
                let stream = if req.tx && self.dma.enabled(6) {
                    6
                } else if req.rx && self.dma.enabled(0) {
                    0
                } else {
                    break;
                };
                let mut bus = Bus {
                    i2c: &mut self.i2c,
                    ram: &mut self.ram,
                };
                let r = self.dma.service(stream, &mut bus);
                if stream == 0 && r == (Serviced::Moved { remaining: 1 }) {
                    self.i2c.dma_eot_1();
                }
            }
        }

        /// Run to the next event (or `limit`), servicing DMA; false: nothing pending.
        fn step(&mut self, limit: Time) -> bool {
            self.run_dma();
            let Some(t) = self.i2c.next_event(self.now, &CLOCKS) else {
                return false;
            };
            if t > limit {
                return false;
            }
            self.now = t;
            self.i2c.advance(t, &CLOCKS);
            self.run_dma();
            true
        }

        /// Wait (as the driver's poll loop does, reading SR1) until `flag` is set, or an error.
        fn wait(&mut self, flag: u16) -> Result<u16, u16> {
            loop {
                let s = self.rd(SR1);
                if s & sr1::ERRORS & !sr1::BERR != 0 {
                    return Err(s);
                }
                if s & flag != 0 {
                    return Ok(s);
                }
                assert!(
                    self.step(Time::MAX),
                    "stuck waiting for {flag:#x}: {:?}",
                    self.i2c
                );
            }
        }

        fn start_dma(&mut self, stream: usize, dir_m2p: bool, mem: u32, n: u32) {
            let base = 0x10 + 0x18 * stream as u32;
            self.dma.write(base + 8, Size::Word, I2C1_BASE + DR);
            self.dma.write(base + 0xC, Size::Word, mem);
            self.dma.write(base + 4, Size::Word, n);
            self.dma.write(base + 0x14, Size::Word, 0);
            let dir = if dir_m2p { 1 } else { 0 } << dcr::DIR_SHIFT;
            let cr = 1 << dcr::CHSEL_SHIFT | dir | dcr::MINC | dcr::TCIE | dcr::TEIE;
            self.dma.write(base, Size::Word, cr);
            self.dma.write(base, Size::Word, cr | dcr::EN);
        }
    }

    /// embassy-stm32 0.6's `write_read` with DMA (i2c/v1.rs `write_frame` then `read_frame`):
    /// the register address out on DMA1 stream 6, a repeated START, `n` bytes in on stream 0
    /// with LAST, then STOP. Returns the bytes or the SR1 that ended it.
    fn embassy_write_read(rig: &mut Rig, reg: u16, n: usize) -> Result<Vec<u8>, u16> {
        // write_frame
        rig.modify(CR2, |v| (v & !(cr2::ITBUFEN | cr2::LAST)) | cr2::DMAEN);
        rig.modify(CR1, |v| v | cr1::START);
        rig.wait(sr1::SB)?;
        assert_eq!(
            rig.rd(CR1) & cr1::START,
            0,
            "START cleared by hardware at SB"
        );
        assert_ne!(rig.rd(SR2) & sr2::MSL, 0);
        rig.wr(DR, 0x33 << 1);
        if let Err(s) = rig.wait(sr1::ADDR) {
            rig.modify(CR1, |v| v | cr1::STOP);
            return Err(s);
        }
        rig.rd(SR2);
        rig.ram[..2].copy_from_slice(&reg.to_be_bytes());
        rig.start_dma(6, true, RAM, 2);
        while rig.dma.enabled(6) {
            let s = rig.rd(SR1);
            if s & sr1::ERRORS & !sr1::BERR != 0 {
                return Err(s);
            }
            assert!(rig.step(Time::MAX));
        }
        rig.modify(CR2, |v| v & !cr2::DMAEN);
        rig.wait(sr1::BTF)?;
        // read_frame (N > 1: LAST set, STOP after the DMA's end)
        rig.modify(CR2, |v| (v & !cr2::ITBUFEN) | cr2::DMAEN | cr2::LAST);
        rig.modify(CR1, |v| v | cr1::START | cr1::ACK);
        rig.wait(sr1::SB)?;
        assert_eq!(rig.rd(CR1) & cr1::START, 0);
        assert_ne!(rig.rd(SR2) & sr2::MSL, 0);
        rig.wr(DR, 0x33 << 1 | 1);
        if let Err(s) = rig.wait(sr1::ADDR) {
            rig.modify(CR1, |v| v | cr1::STOP);
            return Err(s);
        }
        rig.rd(SR2);
        rig.start_dma(0, false, RAM + 0x10, n as u32);
        while rig.dma.enabled(0) {
            let s = rig.rd(SR1);
            if s & sr1::ERRORS & !sr1::BERR != 0 {
                return Err(s);
            }
            assert!(rig.step(Time::MAX));
        }
        rig.modify(CR2, |v| v & !cr2::DMAEN);
        rig.modify(CR1, |v| v | cr1::STOP);
        Ok(rig.ram[0x10..0x10 + n].to_vec())
    }

    fn finish_bus(rig: &mut Rig) {
        while rig.step(Time::MAX) {}
    }

    #[test]
    fn embassy_write_read_of_three_words_with_dma_at_400_khz() {
        let mut rig = Rig::new();
        rig.init();
        {
            let mut d = rig.dev.0.borrow_mut();
            d.words.insert(0x2400, 0x1234);
            d.words.insert(0x2401, 0xABCD);
            d.words.insert(0x2402, 0x0042);
        }
        let t0 = rig.now;
        let bytes = embassy_write_read(&mut rig, 0x2400, 6).unwrap();
        assert_eq!(bytes, [0x12, 0x34, 0xAB, 0xCD, 0x00, 0x42]);
        finish_bus(&mut rig);
        assert_eq!(
            rig.rd(SR2) & (sr2::BUSY | sr2::MSL),
            0,
            "STOP sent, bus free"
        );
        assert_eq!(rig.rd(CR1) & cr1::STOP, 0);
        let log = rig.dev.0.borrow().log.join(" ");
        assert_eq!(
            log, "S33w W24 W00 S33r R12a R34a Raba Rcda R00a R42n P",
            "the last byte NACKed by LAST after EOT-1, then STOP"
        );
        // Timing: START, address + 2 bytes, repeated START, address + 6 bytes, STOP, each
        // byte 9 SCL periods, each condition one: 1 + 27 + 1 + 63 + 1 = 93 periods.
        assert_eq!(rig.now - t0, 93 * SCL);
        // 9 periods of 111 cycles at 45 MHz: 22.2 µs a byte.
        assert_eq!(9 * SCL, 15_984);
        assert_eq!(Clocks::ticks(9 * SCL, 1_000_000), 22);
    }

    #[test]
    fn sb_and_addr_need_their_clearing_sequences() {
        let mut rig = Rig::new();
        rig.init();
        rig.modify(CR1, |v| v | cr1::START);
        assert_ne!(rig.rd(SR2) & sr2::BUSY, 0);
        assert!(rig.step(Time::MAX));
        assert_eq!(rig.now, SCL, "START takes one SCL period");
        // DR written without reading SR1 first: SB stays, nothing is sent.
        rig.wr(DR, 0x66);
        assert!(rig.i2c.next_event(rig.now, &CLOCKS).is_none());
        assert_eq!(rig.rd(SR1), sr1::SB);
        rig.wr(DR, 0x66);
        assert_eq!(rig.i2c.peek(SR1), 0);
        assert!(rig.step(Time::MAX));
        assert_eq!(rig.now, 10 * SCL);
        assert_eq!(rig.i2c.peek(SR1), sr1::ADDR);
        // Reading SR2 without SR1 first leaves ADDR.
        rig.rd(SR2);
        assert_eq!(rig.i2c.peek(SR1), sr1::ADDR);
        rig.rd(SR1);
        assert_eq!(rig.rd(SR2), sr2::MSL | sr2::BUSY | sr2::TRA);
        assert_eq!(rig.i2c.peek(SR1), sr1::TXE, "EV8_1: TXE after ADDR");
        // EV8: a byte into the empty shift register, the next waits in DR.
        rig.wr(DR, 0x01);
        assert_eq!(rig.i2c.peek(SR1), sr1::TXE);
        rig.wr(DR, 0x02);
        assert_eq!(rig.i2c.peek(SR1), 0);
        assert!(rig.step(Time::MAX));
        assert_eq!(rig.i2c.peek(SR1), sr1::TXE);
        assert!(rig.step(Time::MAX));
        assert_eq!(rig.i2c.peek(SR1), sr1::TXE | sr1::BTF, "EV8_2");
        assert!(!rig.step(Time::MAX), "SCL stretched");
        // BTF cleared by SR1 read then DR write.
        rig.rd(SR1);
        rig.wr(DR, 0x03);
        assert_eq!(rig.i2c.peek(SR1), sr1::TXE);
        rig.wait(sr1::BTF).unwrap();
        rig.modify(CR1, |v| v | cr1::STOP);
        finish_bus(&mut rig);
        assert_eq!(rig.rd(SR2), 0);
        assert_eq!(rig.i2c.peek(SR1), 0, "TXE and BTF cleared by the STOP");
        assert_eq!(rig.dev.0.borrow().log.join(" "), "S33w W01 W02 W03 P");
    }

    #[test]
    fn embassy_write_with_stop_and_the_buffer_interrupt() {
        // write_frame(FirstAndLastFrame): a register write (address, value), STOP after BTF.
        let mut rig = Rig::new();
        rig.init();
        rig.modify(CR2, |v| (v & !(cr2::ITBUFEN | cr2::LAST)) | cr2::DMAEN);
        rig.modify(CR1, |v| v | cr1::START);
        rig.wait(sr1::SB).unwrap();
        rig.wr(DR, 0x33 << 1);
        rig.wait(sr1::ADDR).unwrap();
        rig.rd(SR2);
        // TXE with ITEVTEN alone is not an event; with ITBUFEN it is.
        let ev = |rig: &Rig| {
            let mut ev = false;
            rig.i2c.irqs(&mut |i, h| ev |= i == I2C1_EV_IRQ && h);
            ev
        };
        rig.modify(CR2, |v| v | cr2::ITEVTEN);
        assert!(!ev(&rig));
        rig.modify(CR2, |v| v | cr2::ITBUFEN);
        assert!(ev(&rig));
        rig.modify(CR2, |v| v & !(cr2::ITBUFEN | cr2::ITEVTEN));
        rig.ram[..4].copy_from_slice(&[0x80, 0x0D, 0x19, 0x01]);
        rig.start_dma(6, true, RAM, 4);
        while rig.dma.enabled(6) {
            assert!(rig.step(Time::MAX));
        }
        rig.modify(CR2, |v| v & !cr2::DMAEN);
        rig.wait(sr1::BTF).unwrap();
        rig.modify(CR1, |v| v | cr1::STOP);
        finish_bus(&mut rig);
        assert_eq!(rig.rd(SR2), 0);
        assert_eq!(rig.now, (1 + 5 * 9 + 1) * SCL);
        assert_eq!(rig.dev.0.borrow().log.join(" "), "S33w W80 W0d W19 W01 P");
    }

    #[test]
    fn ten_bit_address_header_sets_add10() {
        let mut rig = Rig::new();
        rig.init();
        // A device at 10-bit address 0x2A5: header 11110·10·0 (0xF4), then 0xA5.
        rig.dev.0.borrow_mut().address = 0xF4 >> 1;
        rig.modify(CR1, |v| v | cr1::START);
        rig.wait(sr1::SB).unwrap();
        rig.wr(DR, 0xF4);
        rig.wait(sr1::ADD10).unwrap();
        assert_eq!(rig.i2c.peek(SR1) & sr1::ADDR, 0);
        rig.wr(DR, 0xA5);
        rig.wait(sr1::ADDR).unwrap();
        assert_eq!(rig.i2c.peek(SR1) & sr1::ADD10, 0);
        rig.rd(SR2);
        assert_eq!(rig.i2c.peek(SR1), sr1::TXE);
        assert_eq!(rig.dev.0.borrow().log.join(" "), "S7aw Wa5");
    }

    #[test]
    fn nack_of_address_sets_af_and_the_error_line() {
        let mut rig = Rig::new();
        rig.init();
        rig.dev.0.borrow_mut().address = 0x10;
        rig.modify(CR2, |v| v | cr2::ITERREN | cr2::ITEVTEN);
        let mut lines = Vec::new();
        rig.modify(CR1, |v| v | cr1::START);
        rig.wait(sr1::SB).unwrap();
        rig.i2c.irqs(&mut |i, h| lines.push((i, h)));
        assert_eq!(lines, [(31, true), (32, false)], "SB on the event line");
        rig.wr(DR, 0x33 << 1);
        let s = rig.wait(sr1::ADDR).unwrap_err();
        assert_eq!(s & sr1::AF, sr1::AF);
        assert_eq!(s & sr1::ADDR, 0);
        lines.clear();
        rig.i2c.irqs(&mut |i, h| lines.push((i, h)));
        assert_eq!(lines, [(31, false), (32, true)]);
        // embassy clears AF by writing SR1 = !AF (rc_w0) and sends STOP.
        rig.wr(SR1, !sr1::AF);
        assert_eq!(rig.i2c.peek(SR1) & sr1::AF, 0);
        lines.clear();
        rig.i2c.irqs(&mut |i, h| lines.push((i, h)));
        assert_eq!(lines, [(31, false), (32, false)]);
        rig.modify(CR1, |v| v | cr1::STOP);
        finish_bus(&mut rig);
        assert_eq!(rig.rd(SR2), 0);
    }

    #[test]
    fn nack_of_a_data_byte_sets_af() {
        let mut rig = Rig::new();
        rig.init();
        rig.dev.0.borrow_mut().nack_data = true;
        let s = embassy_write_read(&mut rig, 0x8000, 2).unwrap_err();
        assert_ne!(s & sr1::AF, 0);
        assert_eq!(rig.dev.0.borrow().log.join(" "), "S33w W80");
    }

    #[test]
    fn arbitration_lost_drops_to_slave_mode_and_the_bus_stays_busy_a_while() {
        let mut rig = Rig::new();
        rig.init();
        rig.i2c.lose_arbitration_at_next_byte();
        rig.modify(CR1, |v| v | cr1::START);
        rig.wait(sr1::SB).unwrap();
        rig.wr(DR, 0x33 << 1);
        let s = rig.wait(sr1::ADDR).unwrap_err();
        assert_eq!(s & sr1::ARLO, sr1::ARLO);
        assert_eq!(
            rig.rd(SR2),
            sr2::BUSY,
            "MSL cleared, the other master holds the bus"
        );
        rig.wr(SR1, !sr1::ARLO);
        // embassy sets STOP after the error: in slave mode it waits for the bus's STOP.
        rig.modify(CR1, |v| v | cr1::STOP);
        assert_ne!(rig.rd(CR1) & cr1::STOP, 0);
        // A new START waits for the other master's STOP, then goes ahead.
        let t = rig.now;
        rig.modify(CR1, |v| v | cr1::START);
        rig.wait(sr1::SB).unwrap();
        assert_eq!(rig.now, t + 10 * SCL);
        assert_eq!(rig.rd(CR1) & (cr1::STOP | cr1::START), 0);
        assert_eq!(rig.rd(SR2), sr2::MSL | sr2::BUSY);
    }

    #[test]
    fn sda_held_low_blocks_start_until_swrst() {
        let mut rig = Rig::new();
        rig.init();
        rig.i2c.hold_sda_low(true);
        assert_eq!(rig.rd(SR2), sr2::BUSY);
        rig.modify(CR1, |v| v | cr1::START);
        assert!(!rig.step(Time::MAX), "no START while SDA is low");
        assert_eq!(rig.rd(SR1) & sr1::SB, 0);
        assert_ne!(rig.rd(CR1) & cr1::START, 0, "START stays pending");
        // Released (the board clocks SCL nine times as GPIO): still BUSY, no STOP was seen.
        rig.i2c.hold_sda_low(false);
        assert!(!rig.step(Time::MAX));
        assert_eq!(rig.rd(SR2), sr2::BUSY);
        // The board rebuilds I2C1: init with SWRST clears BUSY; a transfer works again.
        rig.init();
        assert_eq!(rig.rd(SR2), 0);
        assert_eq!(rig.rd(TRISE), 14);
        rig.dev.0.borrow_mut().words.insert(0x800D, 0x1901);
        let b = embassy_write_read(&mut rig, 0x800D, 2).unwrap();
        assert_eq!(b, [0x19, 0x01]);
    }

    #[test]
    fn sda_held_low_mid_byte_loses_arbitration() {
        let mut rig = Rig::new();
        rig.init();
        rig.modify(CR1, |v| v | cr1::START);
        rig.wait(sr1::SB).unwrap();
        rig.wr(DR, 0x33 << 1);
        rig.i2c.hold_sda_low(true);
        let s = rig.wait(sr1::ADDR).unwrap_err();
        assert_ne!(s & sr1::ARLO, 0);
        assert_eq!(rig.rd(SR2), sr2::BUSY);
    }

    #[test]
    fn blocking_receiver_n_bytes_with_ev7_1_and_stretching_without_overrun() {
        // RM0390's N > 2 procedure without DMA, with a slow reader: bytes wait with BTF,
        // none is lost (no OVR in master mode), ACK cleared at BTF with N-2 in DR, N-1 in the
        // shift register, STOP after, N is NACKed.
        let mut rig = Rig::new();
        rig.init();
        rig.dev.0.borrow_mut().words.insert(0, 0x0102);
        rig.dev.0.borrow_mut().words.insert(1, 0x0304);
        rig.modify(CR1, |v| v | cr1::START | cr1::ACK);
        rig.wait(sr1::SB).unwrap();
        rig.wr(DR, 0x33 << 1 | 1);
        rig.wait(sr1::ADDR).unwrap();
        rig.rd(SR2);
        // Let it run: byte 1 in DR, byte 2 in the shift register, then it stalls.
        while rig.step(Time::MAX) {}
        assert_eq!(rig.rd(SR1), sr1::RXNE | sr1::BTF);
        let mut got = vec![rig.rd(DR) as u8];
        // Byte 2 now in DR, byte 3 being received; at BTF: N-2 (2) in DR, N-1 (3) shifted.
        rig.wait(sr1::BTF).unwrap();
        rig.modify(CR1, |v| v & !cr1::ACK);
        got.push(rig.rd(DR) as u8);
        rig.wait(sr1::BTF).unwrap();
        rig.modify(CR1, |v| v | cr1::STOP);
        got.push(rig.rd(DR) as u8);
        rig.wait(sr1::RXNE).unwrap();
        got.push(rig.rd(DR) as u8);
        finish_bus(&mut rig);
        assert_eq!(got, [1, 2, 3, 4]);
        assert_eq!(rig.i2c.peek(SR1) & sr1::OVR, 0);
        assert_eq!(rig.rd(SR2), 0);
        assert_eq!(
            rig.dev.0.borrow().log.join(" "),
            "S33r R01a R02a R03a R04n P"
        );
    }

    #[test]
    fn two_bytes_with_pos_nack_the_second() {
        let mut rig = Rig::new();
        rig.init();
        rig.dev.0.borrow_mut().words.insert(0, 0xBEEF);
        rig.modify(CR1, |v| v | cr1::START | cr1::ACK);
        rig.wait(sr1::SB).unwrap();
        rig.wr(DR, 0x33 << 1 | 1);
        rig.wait(sr1::ADDR).unwrap();
        rig.modify(CR1, |v| (v | cr1::POS) & !cr1::ACK);
        rig.rd(SR2);
        rig.wait(sr1::BTF).unwrap();
        rig.modify(CR1, |v| v | cr1::STOP);
        let a = rig.rd(DR) as u8;
        let b = rig.rd(DR) as u8;
        finish_bus(&mut rig);
        assert_eq!([a, b], [0xBE, 0xEF]);
        assert_eq!(rig.dev.0.borrow().log.join(" "), "S33r Rbea Refn P");
    }

    #[test]
    fn one_byte_nacked_by_ack_cleared_during_addr() {
        let mut rig = Rig::new();
        rig.init();
        rig.dev.0.borrow_mut().words.insert(0, 0x7700);
        rig.modify(CR1, |v| v | cr1::START | cr1::ACK);
        rig.wait(sr1::SB).unwrap();
        rig.wr(DR, 0x33 << 1 | 1);
        rig.wait(sr1::ADDR).unwrap();
        rig.modify(CR1, |v| v & !cr1::ACK);
        rig.rd(SR2);
        rig.modify(CR1, |v| v | cr1::STOP);
        rig.wait(sr1::RXNE).unwrap();
        assert_eq!(rig.rd(DR), 0x77);
        finish_bus(&mut rig);
        assert_eq!(rig.dev.0.borrow().log.join(" "), "S33r R77n P");
    }

    #[test]
    fn bus_error_is_flagged_and_cleared_by_writing_zero() {
        let mut rig = Rig::new();
        rig.init();
        rig.modify(CR2, |v| v | cr2::ITERREN);
        rig.modify(CR1, |v| v | cr1::START);
        rig.i2c.misplaced_start_or_stop();
        assert_ne!(rig.rd(SR1) & sr1::BERR, 0);
        let mut er = false;
        rig.i2c.irqs(&mut |i, h| {
            if i == I2C1_ER_IRQ {
                er = h;
            }
        });
        assert!(er);
        // Writing 1s leaves the error flags; 0 clears.
        rig.wr(SR1, 0xFFFF);
        assert_ne!(rig.rd(SR1) & sr1::BERR, 0);
        rig.wr(SR1, !sr1::BERR);
        assert_eq!(rig.rd(SR1) & sr1::BERR, 0);
    }

    #[test]
    fn standard_mode_timing_and_pe_off_resets_flags() {
        let mut rig = Rig::new();
        rig.modify(CR2, |_| 45);
        // 100 kHz: CCR = 45 MHz / 200 kHz = 225, period 450 cycles (10 µs).
        rig.modify(CCR, |_| 225);
        rig.modify(CR1, |_| cr1::PE | cr1::START);
        assert!(rig.step(Time::MAX));
        assert_eq!(rig.now, 450 * 16);
        assert_eq!(rig.rd(SR1), sr1::SB);
        rig.modify(CR1, |v| v & !cr1::PE);
        assert_eq!(rig.rd(SR1), 0);
        assert_eq!(rig.rd(SR2), 0);
        assert_eq!(rig.rd(CR1), 0);
        assert_eq!(rig.rd(CCR), 225, "configuration kept");
        // Registers are half words: the upper half reads 0, a byte write merges.
        assert_eq!(rig.i2c.read(CCR + 2, Size::Half), 0);
        rig.i2c.write(CCR + 1, Size::Byte, 0x80);
        assert_eq!(rig.rd(CCR), 0x80E1);
    }
}
