//! The USARTs (RM0390 §25) in asynchronous mode: USART2 (the board's console, 115 200 8N1 on
//! the ST-LINK's virtual COM port, interrupt-driven by embassy's `BufferedUart`), and USART1,
//! USART3, USART6 by the same model ([`UsartInstance`]).
//!
//! This file owns a USART's register window, its transmitter (TDR, the shift register, frames
//! timed at the baud rate BRR and OVER8 give from the bus clock), its receiver (bytes the
//! harness queues arrive one frame apart), its status flags with their clear sequences, its
//! interrupt line and its DMA requests.
//!
//! Modelled as RM0390 says:
//! - BRR and OVER8: a bit lasts USARTDIV · 16 (OVER8 = 0: BRR bus clocks) or USARTDIV · 8
//!   (OVER8 = 1: 8 · DIV_Mantissa + DIV_Fraction bits 2:0 clocks); a frame 1 start bit, 8 or 9 data
//!   bits (M; a parity bit, PCE, is one of them) and 0.5, 1, 1.5 or 2 stop bits (CR2.STOP);
//! - transmission: a DR write fills TDR (TXE cleared); the shift register takes it at once when
//!   free (TXE set again), and a frame later the byte is out ([`Usart::take_transmitted`], with
//!   the time its stop bit ends); TC when a frame ends with TDR empty; setting TE sends an idle
//!   frame first (§25.3.2); nothing is sent while UE or TE is clear (a frame under way ends);
//! - reception (UE and RE): a byte arriving sets RXNE, with FE, NF or PE (PE only with PCE) as
//!   the harness asked; a byte arriving while RXNE is still set sets ORE and is lost (DR keeps
//!   the previous byte; the lost byte's own errors are not reported); IDLE once a whole idle
//!   frame follows a reception (and not again until a byte has been received); a byte
//!   arriving while the receiver is disabled is lost;
//! - the clear sequences: PE, FE, NF, ORE and IDLE by a read of SR followed by a read of DR
//!   (the flags that SR read saw set are cleared); RXNE by a read of DR or a 0 written to it;
//!   TC by a read of SR (that saw TC set) followed by a write of DR, or a 0 written to it; SR's
//!   RXNE, TC, LBD and CTS are rc_w0, its other bits read-only;
//! - the interrupt line: PE·PEIE, TXE·TXEIE, TC·TCIE, (RXNE or ORE)·RXNEIE, IDLE·IDLEIE,
//!   LBD·LBDIE, CTS·CTSIE, (FE or ORE or NF)·EIE·DMAR (§25.4, table 148);
//! - DMA requests ([`Usart::dma_requests`]): receive while RXNE and CR3.DMAR, transmit while
//!   TXE and CR3.DMAT.
//!
//! Not modelled (the board never uses them; the registers read back what was written, the
//! bits have no effect): synchronous mode (CLKEN, CPOL, CPHA, LBCL), LIN (LINEN, LBDL, LBDIE:
//! LBD is never set), hardware flow control (RTSE, CTSE, CTSIE: CTS is never set), smartcard,
//! IrDA and half-duplex (SCEN, NACK, IREN, IRLP, HDSEL, GTPR), ONEBIT sampling, the parity's
//! value and the 9th data bit (received bytes are 8 bits, DR bit 8 reads 0), receiver wake-up
//! (CR1.WAKE, CR2.ADD; RWU reads 0, writes ignored) and send break (SBK reads 0, writes
//! ignored). The sender of received bytes runs at exactly the USART's configured baud rate.

use std::collections::VecDeque;

use super::{Clocks, DmaRequests, IrqLines, Peripheral, Size, Time, lanes, merge};

/// One USART instance: where it is, its interrupt line, its bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UsartInstance {
    /// RM0390's name (`"USART2"`).
    pub name: &'static str,
    /// The register window's base address.
    pub base: u32,
    /// The NVIC position of its interrupt line (RM0390 table 38).
    pub irq: u16,
    /// Whether it is clocked by APB2 (PCLK2) rather than APB1 (PCLK1).
    pub apb2: bool,
}

/// USART1: APB2, IRQ 37.
pub const USART1: UsartInstance = UsartInstance {
    name: "USART1",
    base: 0x4001_1000,
    irq: 37,
    apb2: true,
};
/// USART2: APB1, IRQ 38 (the board's console).
pub const USART2: UsartInstance = UsartInstance {
    name: "USART2",
    base: 0x4000_4400,
    irq: 38,
    apb2: false,
};
/// USART3: APB1, IRQ 39.
pub const USART3: UsartInstance = UsartInstance {
    name: "USART3",
    base: 0x4000_4800,
    irq: 39,
    apb2: false,
};
/// USART6: APB2, IRQ 71.
pub const USART6: UsartInstance = UsartInstance {
    name: "USART6",
    base: 0x4001_1400,
    irq: 71,
    apb2: true,
};

/// Register offsets.
const SR: u32 = 0x00;
const DR: u32 = 0x04;
const BRR: u32 = 0x08;
const CR1: u32 = 0x0C;
const CR2: u32 = 0x10;
const CR3: u32 = 0x14;
const GTPR: u32 = 0x18;

/// SR bits.
const PE: u32 = 1 << 0;
const FE: u32 = 1 << 1;
const NF: u32 = 1 << 2;
const ORE: u32 = 1 << 3;
const IDLE: u32 = 1 << 4;
const RXNE: u32 = 1 << 5;
const TC: u32 = 1 << 6;
const TXE: u32 = 1 << 7;
const LBD: u32 = 1 << 8;
const CTS: u32 = 1 << 9;
/// SR's rc_w0 bits.
const SR_RC_W0: u32 = RXNE | TC | LBD | CTS;
/// The flags the SR-then-DR read sequence clears.
const SR_READ_CLEARED: u32 = PE | FE | NF | ORE | IDLE;

/// CR1 bits.
const RE: u32 = 1 << 2;
const TE: u32 = 1 << 3;
const IDLEIE: u32 = 1 << 4;
const RXNEIE: u32 = 1 << 5;
const TCIE: u32 = 1 << 6;
const TXEIE: u32 = 1 << 7;
const PEIE: u32 = 1 << 8;
const PCE: u32 = 1 << 10;
const M: u32 = 1 << 12;
const UE: u32 = 1 << 13;
const OVER8: u32 = 1 << 15;
/// CR1's writable bits (SBK and RWU not modelled).
const CR1_MASK: u32 = 0xBFFC;

/// CR2 bits.
const LBDIE: u32 = 1 << 6;
/// CR2's writable bits.
const CR2_MASK: u32 = 0x7F6F;

/// CR3 bits.
const EIE: u32 = 1 << 0;
const DMAR: u32 = 1 << 6;
const DMAT: u32 = 1 << 7;
const CTSIE: u32 = 1 << 10;
/// CR3's writable bits.
const CR3_MASK: u32 = 0x0FFF;

/// What went wrong with a received byte, as the receiver sees it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RxFault {
    /// A good frame.
    #[default]
    None,
    /// No stop bit where one should be (FE; also a break).
    Framing,
    /// Noise on a sample (NF).
    Noise,
    /// A wrong parity bit (PE, only with parity enabled: otherwise a good frame).
    Parity,
}

/// A byte the transmitter sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TxByte {
    /// The byte.
    pub byte: u8,
    /// When its frame's stop bits ended.
    pub end: Time,
}

/// The transmit shift register's frame under way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Shifting {
    /// The byte, or None: the idle frame sent when TE is set.
    byte: Option<u8>,
    /// When the frame ends.
    end: Time,
}

/// A frame arriving at the receiver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Arriving {
    byte: u8,
    fault: RxFault,
    /// When its stop bit has been sampled (RXNE then).
    end: Time,
}

/// A USART in asynchronous mode.
#[derive(Clone, Debug)]
pub struct Usart {
    inst: UsartInstance,
    sr: u32,
    brr: u32,
    cr1: u32,
    cr2: u32,
    cr3: u32,
    gtpr: u32,
    /// The receive data register.
    rdr: u8,
    /// The transmit data register (None: empty, TXE).
    tdr: Option<u8>,
    shifting: Option<Shifting>,
    transmitted: Vec<TxByte>,
    /// Bytes queued by the harness, not yet on the line.
    rx_queue: VecDeque<(u8, RxFault)>,
    arriving: Option<Arriving>,
    /// When the line, idle since the last reception, has been idle a whole frame (IDLE).
    idle_at: Option<Time>,
    /// The error and idle flags the last SR read saw (the read of DR then clears them).
    seen_errors: u32,
    /// Whether the last SR read saw TC (a write of DR then clears it).
    seen_tc: bool,
    now: Time,
    clocks: Clocks,
}

impl Usart {
    /// The USART `inst` at reset (SR = 0x00C0: TXE and TC set; everything else 0).
    pub fn new(inst: UsartInstance) -> Usart {
        Usart {
            inst,
            sr: TXE | TC,
            brr: 0,
            cr1: 0,
            cr2: 0,
            cr3: 0,
            gtpr: 0,
            rdr: 0,
            tdr: None,
            shifting: None,
            transmitted: Vec::new(),
            rx_queue: VecDeque::new(),
            arriving: None,
            idle_at: None,
            seen_errors: 0,
            seen_tc: false,
            now: 0,
            clocks: Clocks::RESET,
        }
    }

    /// A reset from the RCC (its APBxRSTR bit pulsed): every register back to its reset value
    /// and the transmitter's frame under way cut, at the present time. The receive line is
    /// outside the chip: bytes queued or arriving keep coming (to a disabled receiver); the
    /// bytes already sent stay for [`Usart::take_transmitted`].
    pub fn reset(&mut self) {
        let mut fresh = Usart::new(self.inst);
        fresh.transmitted = std::mem::take(&mut self.transmitted);
        fresh.rx_queue = std::mem::take(&mut self.rx_queue);
        fresh.arriving = self.arriving;
        fresh.now = self.now;
        fresh.clocks = self.clocks;
        *self = fresh;
    }

    /// The instance this models.
    pub fn instance(&self) -> UsartInstance {
        self.inst
    }

    /// Queue `byte` on the receive line (with `fault`), at the present time (the model's, as
    /// last advanced): it starts now if the line is free, else right after the bytes before
    /// it; each takes a frame at the configured baud rate.
    pub fn receive(&mut self, byte: u8, fault: RxFault) {
        self.rx_queue.push_back((byte, fault));
        if self.arriving.is_none() {
            self.start_arrival(self.now);
        }
    }

    /// Queue good bytes on the receive line ([`Usart::receive`] each).
    pub fn receive_bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.receive(b, RxFault::None);
        }
    }

    /// Bytes queued or arriving, not yet received.
    pub fn rx_pending(&self) -> usize {
        self.rx_queue.len() + usize::from(self.arriving.is_some())
    }

    /// The bytes sent since the last call, in order, with the times their frames ended.
    pub fn take_transmitted(&mut self) -> Vec<TxByte> {
        std::mem::take(&mut self.transmitted)
    }

    /// The DMA requests now (RM0390 §25.3.13): receive while RXNE and DMAR, transmit while
    /// TXE and DMAT.
    pub fn dma_requests(&self) -> DmaRequests {
        DmaRequests {
            rx: self.sr & RXNE != 0 && self.cr3 & DMAR != 0,
            tx: self.sr & TXE != 0 && self.cr3 & DMAT != 0,
        }
    }

    /// The baud rate BRR and OVER8 give at `clocks`, bit/s (None while BRR is 0).
    pub fn baud_hz(&self, clocks: &Clocks) -> Option<f64> {
        let bit = self.bit_clocks()?;
        Some(f64::from(self.kernel_hz(clocks)) / bit as f64)
    }

    /// One frame's duration at `clocks` (start, data and stop bits; None while BRR is 0).
    pub fn frame_time(&self, clocks: &Clocks) -> Option<Time> {
        let bit = self.bit_clocks()?;
        let data_bits = if self.cr1 & M != 0 { 9 } else { 8 };
        let stop_halves = match (self.cr2 >> 12) & 3 {
            0 => 2,
            1 => 1,
            2 => 4,
            _ => 3,
        };
        let halves = 2 * (1 + data_bits) + stop_halves;
        Some(Clocks::time_of(
            bit * halves,
            self.kernel_hz(clocks).saturating_mul(2),
        ))
    }

    /// The bus clock, Hz.
    fn kernel_hz(&self, clocks: &Clocks) -> u32 {
        if self.inst.apb2 {
            clocks.pclk2_hz
        } else {
            clocks.pclk1_hz
        }
    }

    /// Bus clocks a bit lasts (None while BRR is 0).
    fn bit_clocks(&self) -> Option<u64> {
        let brr = u64::from(self.brr);
        let bit = if self.cr1 & OVER8 != 0 {
            (brr >> 4) * 8 + (brr & 7)
        } else {
            brr
        };
        (bit != 0).then_some(bit)
    }

    /// The frame time at the clocks last advanced with (one time unit while BRR is 0, so that
    /// nothing stalls).
    fn frame(&self) -> Time {
        self.frame_time(&self.clocks).unwrap_or(1).max(1)
    }

    fn enabled(&self, bit: u32) -> bool {
        self.cr1 & UE != 0 && self.cr1 & bit != 0
    }

    /// The next queued byte starts arriving at `at`.
    fn start_arrival(&mut self, at: Time) {
        if let Some((byte, fault)) = self.rx_queue.pop_front() {
            self.arriving = Some(Arriving {
                byte,
                fault,
                end: at + self.frame(),
            });
            // The line is busy: no idle frame now.
            self.idle_at = None;
        }
    }

    /// The shift register takes TDR's byte if it is free and the transmitter enabled.
    fn load_shift_register(&mut self, at: Time) {
        if self.shifting.is_none() && self.enabled(TE) {
            if let Some(byte) = self.tdr.take() {
                self.shifting = Some(Shifting {
                    byte: Some(byte),
                    end: at + self.frame(),
                });
                self.sr |= TXE;
            }
        }
    }

    /// The earliest of the pending line events.
    fn next_line_event(&self) -> Option<Time> {
        [
            self.shifting.map(|s| s.end),
            self.arriving.map(|a| a.end),
            self.idle_at,
        ]
        .into_iter()
        .flatten()
        .min()
    }

    /// Handle every line event at or before `now`, in time order.
    fn run_to(&mut self, now: Time) {
        while let Some(t) = self.next_line_event().filter(|&t| t <= now) {
            if let Some(s) = self.shifting.filter(|s| s.end == t) {
                self.shifting = None;
                if let Some(byte) = s.byte {
                    self.transmitted.push(TxByte { byte, end: t });
                }
                self.load_shift_register(t);
                if self.shifting.is_none() && s.byte.is_some() {
                    self.sr |= TC;
                }
            } else if let Some(a) = self.arriving.filter(|a| a.end == t) {
                self.arriving = None;
                if self.enabled(RE) {
                    if self.sr & RXNE != 0 {
                        self.sr |= ORE;
                    } else {
                        self.rdr = a.byte;
                        self.sr |= RXNE;
                        self.sr |= match a.fault {
                            RxFault::None => 0,
                            RxFault::Framing => FE,
                            RxFault::Noise => NF,
                            RxFault::Parity if self.cr1 & PCE != 0 => PE,
                            RxFault::Parity => 0,
                        };
                    }
                    self.idle_at = Some(t + self.frame());
                }
                self.start_arrival(t);
            } else {
                self.idle_at = None;
                if self.enabled(RE) {
                    self.sr |= IDLE;
                }
            }
        }
    }

    fn write_cr1(&mut self, value: u32) {
        let was_te = self.enabled(TE);
        self.cr1 = value & CR1_MASK;
        if !was_te && self.enabled(TE) && self.shifting.is_none() {
            // Setting TE sends an idle frame first.
            self.shifting = Some(Shifting {
                byte: None,
                end: self.now + self.frame(),
            });
        }
        self.load_shift_register(self.now);
    }

    /// The register at `offset` (word-aligned), without side effects.
    fn peek(&self, offset: u32) -> u32 {
        match offset {
            SR => self.sr,
            DR => u32::from(self.rdr),
            BRR => self.brr,
            CR1 => self.cr1,
            CR2 => self.cr2,
            CR3 => self.cr3,
            GTPR => self.gtpr,
            _ => 0,
        }
    }
}

impl Peripheral for Usart {
    fn name(&self) -> &'static str {
        self.inst.name
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        let reg = offset & !3;
        let value = self.peek(reg);
        match reg {
            SR => {
                self.seen_errors = self.sr & SR_READ_CLEARED;
                self.seen_tc = self.sr & TC != 0;
            }
            DR => {
                self.sr &= !(RXNE | self.seen_errors);
                self.seen_errors = 0;
            }
            _ => {}
        }
        lanes(value, offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        let reg = offset & !3;
        let value = merge(self.peek(reg), offset, size, value);
        match reg {
            SR => self.sr &= value | !SR_RC_W0,
            DR => {
                if self.seen_tc {
                    self.sr &= !TC;
                    self.seen_tc = false;
                }
                self.tdr = Some(value as u8);
                self.sr &= !TXE;
                self.load_shift_register(self.now);
            }
            BRR => self.brr = value & 0xFFFF,
            CR1 => self.write_cr1(value),
            CR2 => self.cr2 = value & CR2_MASK,
            CR3 => self.cr3 = value & CR3_MASK,
            GTPR => self.gtpr = value & 0xFFFF,
            _ => {}
        }
    }

    fn advance(&mut self, now: Time, clocks: &Clocks) {
        self.clocks = *clocks;
        if now > self.now {
            self.run_to(now);
            self.now = now;
        }
    }

    fn next_event(&self, now: Time, _clocks: &Clocks) -> Option<Time> {
        self.next_line_event().map(|t| t.max(now + 1))
    }
}

impl IrqLines for Usart {
    fn irqs(&self, line: &mut dyn FnMut(u16, bool)) {
        let (sr, cr1) = (self.sr, self.cr1);
        let on = |flags: u32, enable: bool| enable && sr & flags != 0;
        let high = on(PE, cr1 & PEIE != 0)
            || on(TXE, cr1 & TXEIE != 0)
            || on(TC, cr1 & TCIE != 0)
            || on(RXNE | ORE, cr1 & RXNEIE != 0)
            || on(IDLE, cr1 & IDLEIE != 0)
            || on(LBD, self.cr2 & LBDIE != 0)
            || on(CTS, self.cr3 & CTSIE != 0)
            || on(FE | ORE | NF, self.cr3 & EIE != 0 && self.cr3 & DMAR != 0);
        line(self.inst.irq, high);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The board's clocks: PCLK1 45 MHz.
    const BOARD: Clocks = Clocks {
        sysclk_hz: 180_000_000,
        hclk_hz: 180_000_000,
        pclk1_hz: 45_000_000,
        pclk2_hz: 90_000_000,
        tim_apb1_hz: 90_000_000,
        tim_apb2_hz: 180_000_000,
        lsi_hz: 32_000,
    };

    /// A 115 200 8N1 frame from BRR 391 (embassy's rounding of 45 MHz / 115 200): 3 910 bus
    /// clocks.
    const FRAME: Time = 62_560;

    fn r(u: &mut Usart, offset: u32) -> u32 {
        u.read(offset, Size::Word)
    }

    /// Read-modify-write of the register at `offset`.
    fn rmw(u: &mut Usart, offset: u32, f: impl FnOnce(u32) -> u32) {
        let v = f(r(u, offset));
        w(u, offset, v);
    }

    fn w(u: &mut Usart, offset: u32, value: u32) {
        u.write(offset, Size::Word, value);
    }

    fn irq(u: &Usart) -> bool {
        let mut high = None;
        u.irqs(&mut |n, h| {
            assert_eq!(n, 38);
            high = Some(h);
        });
        high.unwrap()
    }

    /// embassy's BufferedUart set-up, at time 0, then run past TE's idle frame.
    fn console() -> Usart {
        let mut u = Usart::new(USART2);
        u.advance(0, &BOARD);
        w(&mut u, CR3, 0);
        w(&mut u, CR1, 0);
        w(&mut u, BRR, 391);
        w(&mut u, CR2, 0);
        w(&mut u, CR1, UE | TE | RE);
        rmw(&mut u, CR1, |v| v | RXNEIE | IDLEIE);
        u.advance(FRAME, &BOARD);
        u
    }

    #[test]
    fn a_byte_at_115200_takes_a_ten_bit_frame() {
        let u = console();
        assert_eq!(u.frame_time(&BOARD), Some(FRAME));
        // 86.89 µs: 86.8 µs (10 bits at 115 200) within BRR's rounding.
        let us = FRAME as f64 / 720.0;
        assert!((us - 1e7 / 115_200.0).abs() < 0.1, "{us}");
        let baud = u.baud_hz(&BOARD).unwrap();
        assert!((baud - 115_200.0).abs() / 115_200.0 < 0.002, "{baud}");
        // OVER8: mantissa · 8 + fraction[2:0] clocks a bit.
        let mut v = Usart::new(USART1);
        w(&mut v, BRR, (48 << 4) | 7);
        w(&mut v, CR1, OVER8);
        assert_eq!(v.baud_hz(&BOARD), Some(90e6 / (48.0 * 8.0 + 7.0)));
        // Two stop bits, 9 data bits: 12 bits.
        w(&mut v, CR1, M);
        w(&mut v, CR2, 2 << 12);
        w(&mut v, BRR, 16);
        assert_eq!(
            v.frame_time(&BOARD),
            Some(Clocks::time_of(16 * 12, 90_000_000))
        );
    }

    #[test]
    fn transmission_txe_and_tc() {
        let mut u = console();
        let t0 = 10 * FRAME;
        u.advance(t0, &BOARD);
        assert_eq!(r(&mut u, SR), TXE | TC);
        // DR → shift register at once: TXE again, TC cleared by the SR read + DR write.
        w(&mut u, DR, u32::from(b'A'));
        assert_eq!(r(&mut u, SR), TXE);
        w(&mut u, DR, u32::from(b'B'));
        assert_eq!(r(&mut u, SR), 0, "TDR full");
        rmw(&mut u, CR1, |v| v | TXEIE);
        assert!(!irq(&u));
        assert_eq!(u.next_event(t0, &BOARD), Some(t0 + FRAME));
        u.advance(t0 + FRAME - 1, &BOARD);
        assert!(u.take_transmitted().is_empty());
        u.advance(t0 + FRAME, &BOARD);
        assert_eq!(
            u.take_transmitted(),
            vec![TxByte {
                byte: b'A',
                end: t0 + FRAME
            }]
        );
        assert_eq!(r(&mut u, SR), TXE, "B in the shift register, no TC");
        assert!(irq(&u));
        rmw(&mut u, CR1, |v| (v & !TXEIE) | TCIE);
        assert!(!irq(&u));
        u.advance(t0 + 2 * FRAME, &BOARD);
        assert_eq!(u.take_transmitted()[0].byte, b'B');
        assert_eq!(r(&mut u, SR), TXE | TC);
        assert!(irq(&u));
        // TC cleared by writing 0 (the 1s leave the rest).
        w(&mut u, SR, !TC);
        assert_eq!(r(&mut u, SR), TXE);
        assert!(!irq(&u));
        assert_eq!(u.next_event(t0 + 2 * FRAME, &BOARD), None);
        // A DR write without an SR read first leaves TC.
        w(&mut u, SR, 0xFFFF);
        let mut v = console();
        w(&mut v, DR, 1);
        assert_eq!(v.sr & TC, TC);
    }

    #[test]
    fn embassys_interrupt_driven_transmission_streams_back_to_back() {
        // BufferedUart's write: TXEIE set; its interrupt feeds DR from the ring while TXE,
        // sets TCIE with the last byte, and on TC clears TC (SR read-modify-write) and TCIE.
        let mut u = console();
        let t0 = u.now;
        let mut ring: VecDeque<u8> = b"ok\n".iter().copied().collect();
        rmw(&mut u, CR1, |v| v | TXEIE);
        let mut t = t0;
        let mut interrupts = 0;
        while t < t0 + 10 * FRAME {
            u.advance(t, &BOARD);
            if irq(&u) {
                interrupts += 1;
                let sr = r(&mut u, SR);
                if sr & TC != 0 && r(&mut u, CR1) & TCIE != 0 {
                    rmw(&mut u, SR, |v| v & !TC);
                    rmw(&mut u, CR1, |v| v & !TCIE);
                }
                if r(&mut u, SR) & TXE != 0 {
                    match ring.pop_front() {
                        Some(b) => {
                            rmw(&mut u, CR1, |v| v | TXEIE);
                            if ring.is_empty() {
                                rmw(&mut u, CR1, |v| v | TCIE);
                            }
                            w(&mut u, DR, u32::from(b));
                        }
                        None => rmw(&mut u, CR1, |v| v & !TXEIE),
                    }
                }
                // Still pending: the handler runs again at once.
                assert!(interrupts < 20);
                continue;
            }
            t = u.next_event(t, &BOARD).unwrap_or(t + FRAME).min(t + FRAME);
        }
        let sent = u.take_transmitted();
        let bytes: Vec<u8> = sent.iter().map(|s| s.byte).collect();
        assert_eq!(bytes, b"ok\n");
        // The shift register never idles between them: one frame apart.
        assert_eq!(sent[0].end, t0 + FRAME);
        assert_eq!(sent[1].end, t0 + 2 * FRAME);
        assert_eq!(sent[2].end, t0 + 3 * FRAME);
        assert!(!irq(&u), "all interrupts disabled again");
        assert_eq!(r(&mut u, CR1) & (TXEIE | TCIE), 0);
        // 'o' and 'k' at once (TDR and the shift register), '\n' a frame later, the ring
        // empty (TXEIE off) after it, then TC.
        assert_eq!(interrupts, 5);
    }

    #[test]
    fn setting_te_sends_an_idle_frame_first() {
        let mut u = Usart::new(USART2);
        u.advance(0, &BOARD);
        w(&mut u, BRR, 391);
        w(&mut u, CR1, UE | TE);
        w(&mut u, DR, u32::from(b'x'));
        // TXE clear: the byte waits behind the idle frame (TC stays: no SR read before).
        assert_eq!(r(&mut u, SR), TC);
        u.advance(2 * FRAME, &BOARD);
        assert_eq!(u.take_transmitted()[0].end, 2 * FRAME);
        // Disabled transmitter: TDR holds its byte.
        w(&mut u, CR1, UE);
        w(&mut u, DR, u32::from(b'y'));
        u.advance(10 * FRAME, &BOARD);
        assert!(u.take_transmitted().is_empty());
        assert_eq!(r(&mut u, SR) & TXE, 0);
    }

    #[test]
    fn reception_rxne_and_idle() {
        let mut u = console();
        let t0 = 5 * FRAME;
        u.advance(t0, &BOARD);
        u.receive(b'h', RxFault::None);
        assert_eq!(u.next_event(t0, &BOARD), Some(t0 + FRAME));
        u.advance(t0 + FRAME - 1, &BOARD);
        assert_eq!(r(&mut u, SR) & RXNE, 0);
        assert!(!irq(&u));
        u.advance(t0 + FRAME, &BOARD);
        assert_eq!(r(&mut u, SR) & (RXNE | IDLE), RXNE);
        assert!(irq(&u));
        assert_eq!(r(&mut u, DR), u32::from(b'h'));
        assert_eq!(r(&mut u, SR) & RXNE, 0);
        assert!(!irq(&u));
        // A whole idle frame later: IDLE.
        u.advance(t0 + 2 * FRAME - 1, &BOARD);
        assert_eq!(r(&mut u, SR) & IDLE, 0);
        u.advance(t0 + 2 * FRAME, &BOARD);
        assert_eq!(r(&mut u, SR) & IDLE, IDLE);
        assert!(irq(&u));
        // embassy's handler: SR then DR clears it.
        let _ = r(&mut u, SR);
        let _ = r(&mut u, DR);
        assert_eq!(r(&mut u, SR) & IDLE, 0);
        assert!(!irq(&u));
        // No reception since: no IDLE again.
        u.advance(t0 + 20 * FRAME, &BOARD);
        assert_eq!(r(&mut u, SR) & IDLE, 0);
        assert_eq!(u.next_event(t0 + 20 * FRAME, &BOARD), None);
        // Back-to-back bytes: no IDLE between them, one after the last.
        let t1 = u.now;
        u.receive_bytes(b"ok");
        u.advance(t1 + FRAME, &BOARD);
        assert_eq!(r(&mut u, DR), u32::from(b'o'));
        u.advance(t1 + 2 * FRAME, &BOARD);
        assert_eq!(r(&mut u, SR) & (RXNE | IDLE), RXNE);
        assert_eq!(r(&mut u, DR), u32::from(b'k'));
        u.advance(t1 + 3 * FRAME, &BOARD);
        assert_eq!(r(&mut u, SR) & IDLE, IDLE);
    }

    #[test]
    fn overrun_loses_the_new_byte() {
        let mut u = console();
        let t0 = u.now;
        u.receive_bytes(b"abc");
        assert_eq!(u.rx_pending(), 3);
        u.advance(t0 + 3 * FRAME, &BOARD);
        assert_eq!(u.rx_pending(), 0);
        assert_eq!(r(&mut u, SR) & (RXNE | ORE), RXNE | ORE);
        // RXNEIE also covers ORE: with RXNE cleared by writing 0, ORE holds the line.
        w(&mut u, SR, !RXNE);
        assert!(irq(&u));
        // DR keeps the first byte; SR then DR clears ORE.
        let _ = r(&mut u, SR);
        assert_eq!(r(&mut u, DR), u32::from(b'a'));
        assert_eq!(r(&mut u, SR) & (RXNE | ORE), 0);
        assert!(!irq(&u));
        // Other accesses between the SR read and the DR read keep the sequence.
        let t1 = u.now;
        u.receive(b'd', RxFault::None);
        u.receive(b'e', RxFault::None);
        u.advance(t1 + 2 * FRAME, &BOARD);
        let _ = r(&mut u, SR);
        u.advance(t1 + 2 * FRAME + 1, &BOARD);
        w(&mut u, SR, 0xFFFF);
        assert_eq!(r(&mut u, DR), u32::from(b'd'));
        assert_eq!(r(&mut u, SR) & (RXNE | ORE), 0);
    }

    #[test]
    fn framing_noise_and_parity_errors() {
        let mut u = console();
        let t0 = u.now;
        u.receive(0x00, RxFault::Framing);
        u.advance(t0 + FRAME, &BOARD);
        // The flag comes with the byte; a DR read without an SR read first leaves it.
        assert_eq!(u.sr & (RXNE | FE), RXNE | FE);
        assert_eq!(r(&mut u, DR), 0);
        assert_eq!(u.sr & (RXNE | FE), FE);
        // SR, then DR: cleared. (An IDLE arriving in between is not: that SR read did not
        // see it.)
        let _ = r(&mut u, SR);
        u.advance(t0 + 2 * FRAME, &BOARD);
        let _ = r(&mut u, DR);
        assert_eq!(u.sr & (FE | IDLE), IDLE);
        // Noise.
        let t1 = u.now;
        u.receive(b'n', RxFault::Noise);
        u.advance(t1 + FRAME, &BOARD);
        assert_eq!(u.sr & (RXNE | NF), RXNE | NF);
        w(&mut u, CR1, UE | TE | RE);
        assert!(!irq(&u), "NF raises no interrupt of its own");
        w(&mut u, CR1, UE | TE | RE | RXNEIE | IDLEIE);
        let _ = r(&mut u, SR);
        let _ = r(&mut u, DR);
        assert_eq!(u.sr & NF, 0);
        // Parity: only with PCE; PEIE's interrupt.
        let t2 = u.now;
        u.receive(b'p', RxFault::Parity);
        u.advance(t2 + FRAME, &BOARD);
        assert_eq!(u.sr & PE, 0);
        let _ = r(&mut u, DR);
        w(&mut u, CR1, UE | TE | RE | PCE | PEIE);
        let t3 = u.now;
        u.receive(b'p', RxFault::Parity);
        u.advance(t3 + FRAME, &BOARD);
        assert_eq!(u.sr & (RXNE | PE), RXNE | PE);
        assert!(irq(&u));
        // EIE (with DMAR) for FE/NF/ORE.
        let _ = r(&mut u, SR);
        let _ = r(&mut u, DR);
        w(&mut u, CR1, UE | TE | RE);
        w(&mut u, CR3, EIE | DMAR);
        let t4 = u.now;
        u.receive(b'f', RxFault::Framing);
        u.advance(t4 + FRAME, &BOARD);
        assert_eq!(
            u.dma_requests(),
            DmaRequests {
                rx: true,
                tx: false
            }
        );
        let _ = r(&mut u, DR);
        assert_eq!(u.dma_requests(), DmaRequests::default());
        assert!(irq(&u), "FE with EIE and DMAR");
        w(&mut u, CR3, DMAT);
        assert!(!irq(&u));
        assert_eq!(
            u.dma_requests(),
            DmaRequests {
                rx: false,
                tx: true
            }
        );
    }

    #[test]
    fn an_rcc_reset_cuts_the_transmitter_but_not_the_line() {
        let mut u = console();
        let t0 = u.now;
        w(&mut u, DR, u32::from(b'q'));
        u.receive(b'r', RxFault::None);
        u.advance(t0 + FRAME / 2, &BOARD);
        u.reset();
        assert_eq!(r(&mut u, SR), TXE | TC);
        assert_eq!(r(&mut u, CR1), 0);
        u.advance(t0 + 3 * FRAME, &BOARD);
        assert!(u.take_transmitted().is_empty());
        assert_eq!(u.rx_pending(), 0);
        assert_eq!(r(&mut u, SR), TXE | TC, "the byte met a disabled receiver");
    }

    #[test]
    fn a_disabled_receiver_loses_bytes() {
        let mut u = console();
        w(&mut u, CR1, UE | TE);
        let t0 = u.now;
        u.receive(b'z', RxFault::None);
        u.advance(t0 + 3 * FRAME, &BOARD);
        assert_eq!(u.sr & (RXNE | IDLE | ORE), 0);
        assert_eq!(u.rx_pending(), 0);
    }

    #[test]
    fn sr_read_only_bits_and_reserved_control_bits() {
        let mut u = console();
        w(&mut u, SR, 0);
        assert_eq!(r(&mut u, SR), TXE, "TXE is read-only, TC rc_w0");
        w(&mut u, CR1, 0xFFFF);
        assert_eq!(r(&mut u, CR1), 0xBFFC, "SBK, RWU not modelled");
        w(&mut u, CR2, 0xFFFF);
        assert_eq!(r(&mut u, CR2), 0x7F6F);
        w(&mut u, CR3, 0xFFFF);
        assert_eq!(r(&mut u, CR3), 0x0FFF);
        w(&mut u, GTPR, 0x1_2345);
        assert_eq!(r(&mut u, GTPR), 0x2345);
        // A byte write of BRR's high byte.
        u.write(BRR + 1, Size::Byte, 0x02);
        assert_eq!(r(&mut u, BRR), 0x0287);
    }

    #[test]
    fn the_boards_interrupt_sequence_takes_bytes_and_finds_losses() {
        // serial::RxLossWatch reads SR, then embassy reads SR, then DR (RXNE, ORE or IDLE).
        fn isr(u: &mut Usart) -> (u32, Option<u8>) {
            let watch = r(u, SR);
            let sr = r(u, SR);
            let dr = (sr & (RXNE | ORE | IDLE) != 0).then(|| r(u, DR) as u8);
            (watch, dr)
        }
        let mut u = console();
        let t0 = u.now;
        u.receive_bytes(b"set");
        u.advance(t0 + FRAME, &BOARD);
        assert!(irq(&u));
        assert_eq!(isr(&mut u), (TXE | TC | RXNE, Some(b's')));
        assert!(!irq(&u));
        // The interrupt two frames late: 'e' in DR, 't' lost.
        u.advance(t0 + 3 * FRAME, &BOARD);
        assert_eq!(isr(&mut u), (TXE | TC | RXNE | ORE, Some(b'e')));
        assert!(!irq(&u));
        u.advance(t0 + 4 * FRAME, &BOARD);
        assert_eq!(isr(&mut u), (TXE | TC | IDLE, Some(b'e')));
        assert!(!irq(&u));
    }
}
