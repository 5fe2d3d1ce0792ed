//! The embedded flash memory interface (FLASH, RM0390 §3) at 0x4002_3C00 and the 512 KiB
//! array it owns at 0x0800_0000: sectors 0–3 of 16 KiB, 4 of 64 KiB, 5–7 of 128 KiB.
//!
//! Registers: ACR (LATENCY, PRFTEN, ICEN, DCEN, ICRST, DCRST: stored and read back at once;
//! the wait states and caches do not change timing here), KEYR (0x45670123 then 0xCDEF89AB
//! clears CR.LOCK; any other sequence — a wrong key, or a key while CR is already unlocked —
//! is the "wrong sequence" of RM0390 §3.5.1 that returns a bus error and locks CR until the
//! next reset: [`Flash::take_bus_error`] tells the chip), OPTKEYR (0x08192A3B then
//! 0x4C5D6E7F clears OPTCR.OPTLOCK, the same rule), SR (EOP, OPERR, WRPERR, PGAERR, PGPERR,
//! PGSERR write-1-to-clear; RDERR never sets: PCROP is not modelled; BSY), CR (PG, SER,
//! MER, SNB, PSIZE, STRT, EOPIE, ERRIE, LOCK; not writable while LOCK or BSY is set), OPTCR
//! (the option bytes: written while OPTLOCK is clear, programmed by OPTSTRT after BSY for
//! [`OPTION_PROGRAM_TIME`]; nWRP's write protection takes effect then).
//!
//! The array: the CPU's writes to it go through [`Flash::program`], its reads through
//! [`Flash::read_array`]; [`Flash::load_elf`] (or [`Flash::load`]) puts an ELF's loadable
//! segments in at start and
//! [`Flash::array`] reads the whole array back (a saved settings record). Programming
//! follows RM0390 §3.5.4: it needs CR.PG (else PGSERR), an access of PSIZE's width (else
//! PGPERR), not crossing a 128-bit row (else PGAERR), to a sector nWRP leaves writable (else
//! WRPERR); errors program nothing and set OPERR with ERRIE. It only clears bits (the new
//! contents are old AND new): writing over a programmed location is allowed and gives no
//! error on the F4 ("Successive write operations are possible without the need of an erase
//! operation when changing bits from 1 to 0"). An erase sets its bytes to 0xFF. SER with MER
//! erases nothing (RM0390: "neither sector nor mass erase can be performed").
//!
//! Timing: BSY holds for DS10693's typical times (from its "Flash memory programming" table,
//! as recalled for the F446, not re-checked here): a program access
//! [`PROGRAM_TIME`] (16 µs); a sector erase 16 KiB 400/300/250 ms, 64 KiB 1.2/0.7/0.55 s,
//! 128 KiB 2/1.3/1 s, mass erase 16/11/8 s at PSIZE x8/x16/x32 (x64 as x32). The contents
//! change when the operation ends; EOP sets then if EOPIE is set (RM0390 §3.8.4), and STRT
//! reads 1 until BSY clears. On the chip a read or write of the array while BSY is set
//! stalls the bus until it clears: the chip stalls the core until [`Flash::busy_until`]; a
//! program access that still arrives while busy starts when the running operation ends.
//!
//! Not modelled: read protection (RDP is stored), PCROP (SPRMOD), the OTP area, the
//! option bytes' BOR level, watchdog and reset-on-stop bits' effects (stored only).

use super::{Clocks, IrqLines, Peripheral, Size, TIME_HZ, Time, lanes, merge};

/// The array's base address.
pub const FLASH_BASE: u32 = 0x0800_0000;
/// The array's size, bytes (512 KiB).
pub const FLASH_SIZE_BYTES: usize = 512 * 1024;
/// The flash's global interrupt (RM0390 table 38).
pub const FLASH_IRQ: u16 = 4;
const MILLISECOND: Time = TIME_HZ / 1_000;
/// A program access's BSY time (DS10693: word programming 16 µs typical).
pub const PROGRAM_TIME: Time = 16 * TIME_HZ / 1_000_000;
/// The option bytes' programming time (chosen: the order of a 16 KiB sector erase).
pub const OPTION_PROGRAM_TIME: Time = 250 * MILLISECOND;

/// The first key of the unlock sequence.
pub const KEY1: u32 = 0x4567_0123;
/// The second key of the unlock sequence.
pub const KEY2: u32 = 0xCDEF_89AB;
/// The option bytes' first key.
pub const OPTKEY1: u32 = 0x0819_2A3B;
/// The option bytes' second key.
pub const OPTKEY2: u32 = 0x4C5D_6E7F;

/// Register offsets (RM0390 §3.8.7).
pub mod reg {
    /// Access control.
    pub const ACR: u32 = 0x00;
    /// Key.
    pub const KEYR: u32 = 0x04;
    /// Option key.
    pub const OPTKEYR: u32 = 0x08;
    /// Status.
    pub const SR: u32 = 0x0C;
    /// Control.
    pub const CR: u32 = 0x10;
    /// Option control.
    pub const OPTCR: u32 = 0x14;
}

/// FLASH_SR bits.
pub mod sr {
    /// End of operation.
    pub const EOP: u32 = 1 << 0;
    /// Operation error.
    pub const OPERR: u32 = 1 << 1;
    /// Write protection error.
    pub const WRPERR: u32 = 1 << 4;
    /// Programming alignment error.
    pub const PGAERR: u32 = 1 << 5;
    /// Programming parallelism error.
    pub const PGPERR: u32 = 1 << 6;
    /// Programming sequence error.
    pub const PGSERR: u32 = 1 << 7;
    /// Read protection error (PCROP).
    pub const RDERR: u32 = 1 << 8;
    /// Busy.
    pub const BSY: u32 = 1 << 16;
    /// The write-1-to-clear flags.
    pub const W1C: u32 = EOP | OPERR | WRPERR | PGAERR | PGPERR | PGSERR | RDERR;
}

/// FLASH_CR bits.
pub mod cr {
    /// Programming.
    pub const PG: u32 = 1 << 0;
    /// Sector erase.
    pub const SER: u32 = 1 << 1;
    /// Mass erase.
    pub const MER: u32 = 1 << 2;
    /// Sector number (4 bits).
    pub const SNB_SHIFT: u32 = 3;
    /// Program size (2 bits: x8, x16, x32, x64).
    pub const PSIZE_SHIFT: u32 = 8;
    /// Start an erase.
    pub const STRT: u32 = 1 << 16;
    /// End of operation interrupt enable.
    pub const EOPIE: u32 = 1 << 24;
    /// Error interrupt enable.
    pub const ERRIE: u32 = 1 << 25;
    /// Lock.
    pub const LOCK: u32 = 1 << 31;
    /// The writable bits (LOCK only sets).
    pub const MASK: u32 = PG | SER | MER | (0xF << SNB_SHIFT) | (3 << PSIZE_SHIFT) | EOPIE | ERRIE;
}

/// FLASH_OPTCR bits.
pub mod optcr {
    /// Options lock.
    pub const OPTLOCK: u32 = 1 << 0;
    /// Options start.
    pub const OPTSTRT: u32 = 1 << 1;
    /// The reset value (the factory option bytes: RDP 0xAA, no write protection).
    pub const RESET: u32 = 0x0FFF_AAED;
    /// The option bits (BOR_LEV, WDG_SW, nRST_STOP, nRST_STDBY, RDP, nWRP, SPRMOD).
    pub const OPTIONS: u32 = 0x80FF_FFEC;
}

const ACR_MASK: u32 = 0x1F0F;
/// OPTCR's reserved bits 27:24, which read 1.
const OPTCR_RESERVED: u32 = 0x0F00_0000;

/// The byte offset in the array and size of sector `n` (0–7).
pub fn sector_range(n: u32) -> Option<(usize, usize)> {
    const KIB: usize = 1024;
    match n {
        0..=3 => Some((n as usize * 16 * KIB, 16 * KIB)),
        4 => Some((64 * KIB, 64 * KIB)),
        5..=7 => Some(((n as usize - 4) * 128 * KIB, 128 * KIB)),
        _ => None,
    }
}

/// The sector holding byte offset `offset` of the array.
pub fn sector_of(offset: usize) -> u32 {
    (0..8)
        .find(|&n| sector_range(n).is_some_and(|(s, l)| (s..s + l).contains(&offset)))
        .unwrap_or(7)
}

/// The typical erase time of `bytes` (16, 64, 128 KiB or the whole 512 KiB) at PSIZE
/// `psize` (0 x8, 1 x16, 2 and 3 x32), DS10693.
fn erase_time(bytes: usize, psize: u32) -> Time {
    let ms: [u64; 3] = match bytes / 1024 {
        16 => [400, 300, 250],
        64 => [1_200, 700, 550],
        128 => [2_000, 1_300, 1_000],
        _ => [16_000, 11_000, 8_000],
    };
    ms[psize.min(2) as usize] * MILLISECOND
}

/// What the flash is busy with.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Op {
    /// Bytes to AND into the array at an offset.
    Program { offset: usize, bytes: Vec<u8> },
    /// A range to set to 0xFF (empty: nothing, as with SER and MER).
    Erase { offset: usize, len: usize },
    /// Option bytes to take.
    Options { value: u32 },
}

/// A failed key sequence (a bus error on the chip).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BusError {
    /// The register written.
    pub offset: u32,
    /// The value written.
    pub value: u32,
}

/// The flash interface and its array.
#[derive(Clone, Debug)]
pub struct Flash {
    array: Vec<u8>,
    now: Time,
    acr: u32,
    sr: u32,
    cr: u32,
    optcr: u32,
    /// The option bytes in effect (nWRP's protection).
    options: u32,
    key_stage: u8,
    opt_key_stage: u8,
    /// A wrong key sequence: CR (or OPTCR) stays locked until reset.
    cr_locked_out: bool,
    optcr_locked_out: bool,
    bus_error: Option<BusError>,
    busy: Option<(Time, Op)>,
}

impl Default for Flash {
    fn default() -> Self {
        Self::new()
    }
}

impl Flash {
    /// An erased array (all 0xFF) and the interface after reset.
    pub fn new() -> Flash {
        Flash {
            array: vec![0xFF; FLASH_SIZE_BYTES],
            now: 0,
            acr: 0,
            sr: 0,
            cr: cr::LOCK,
            optcr: optcr::RESET,
            options: optcr::RESET,
            key_stage: 0,
            opt_key_stage: 0,
            cr_locked_out: false,
            optcr_locked_out: false,
            bus_error: None,
            busy: None,
        }
    }

    /// A system reset: the registers to their reset values (CR locked again, OPTCR from the
    /// option bytes); an operation under way completes first (the array is not lost); the
    /// array is kept.
    pub fn reset(&mut self) {
        if let Some((_, op)) = self.busy.take() {
            self.apply(op);
        }
        self.acr = 0;
        self.sr = 0;
        self.cr = cr::LOCK;
        self.optcr = (self.options & optcr::OPTIONS) | (optcr::RESET & !optcr::OPTIONS);
        self.key_stage = 0;
        self.opt_key_stage = 0;
        self.cr_locked_out = false;
        self.optcr_locked_out = false;
        self.bus_error = None;
    }

    /// Put `bytes` at address `addr` (0x0800_0000..) of the array, as a programmer would (an
    /// ELF's loadable segments at start). Err: the range is outside the array.
    pub fn load(&mut self, addr: u32, bytes: &[u8]) -> Result<(), String> {
        let off = self
            .offset(addr, bytes.len() as u32)
            .ok_or_else(|| format!("{addr:#010x}+{:#x} is outside the flash", bytes.len()))?;
        self.array[off..off + bytes.len()].copy_from_slice(bytes);
        Ok(())
    }

    /// Load an ELF file's (32-bit little-endian, the board's `thermorph-board`) loadable
    /// segments whose load address (`p_paddr`: `.data`'s initial values are at theirs in
    /// flash) is in the flash, as a programmer would; segments elsewhere (RAM: `.bss`, the
    /// retained RAM) are skipped. Returns the bytes loaded; Err: not such an ELF, or a
    /// segment running past the flash's end.
    pub fn load_elf(&mut self, elf: &[u8]) -> Result<usize, String> {
        let u16_at = |o: usize| -> Result<u32, String> {
            elf.get(o..o + 2)
                .map(|b| u32::from(u16::from_le_bytes([b[0], b[1]])))
                .ok_or_else(|| format!("ELF truncated at {o:#x}"))
        };
        let u32_at = |o: usize| -> Result<u32, String> {
            elf.get(o..o + 4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .ok_or_else(|| format!("ELF truncated at {o:#x}"))
        };
        if elf.get(..6) != Some(&[0x7F, b'E', b'L', b'F', 1, 1]) {
            return Err("not a 32-bit little-endian ELF".into());
        }
        let (phoff, phentsize, phnum) = (u32_at(0x1C)?, u16_at(0x2A)?, u16_at(0x2C)?);
        let mut loaded = 0;
        for i in 0..phnum {
            let ph = (phoff + i * phentsize) as usize;
            let (kind, offset, paddr, filesz) = (
                u32_at(ph)?,
                u32_at(ph + 4)?,
                u32_at(ph + 12)?,
                u32_at(ph + 16)?,
            );
            let in_flash = (FLASH_BASE..FLASH_BASE + FLASH_SIZE_BYTES as u32).contains(&paddr);
            if kind != 1 || filesz == 0 || !in_flash {
                continue;
            }
            let bytes = elf
                .get(offset as usize..(offset + filesz) as usize)
                .ok_or_else(|| format!("segment {i} runs past the file's end"))?;
            self.load(paddr, bytes)?;
            loaded += bytes.len();
        }
        Ok(loaded)
    }

    /// The whole array (512 KiB from 0x0800_0000) as it is now.
    pub fn array(&self) -> &[u8] {
        &self.array
    }

    /// A read of `size` at address `addr` of the array (little-endian). None: outside it.
    /// While BSY is set the chip stalls such a read until [`Flash::busy_until`].
    pub fn read_array(&self, addr: u32, size: Size) -> Option<u32> {
        let off = self.offset(addr, size.bytes())?;
        Some(
            self.array[off..off + size.bytes() as usize]
                .iter()
                .rev()
                .fold(0, |v, b| (v << 8) | u32::from(*b)),
        )
    }

    /// When the operation under way ends (BSY clears), or None.
    pub fn busy_until(&self) -> Option<Time> {
        self.busy.as_ref().map(|(t, _)| *t)
    }

    /// The last failed key sequence since asked (the chip raises a bus fault for it).
    pub fn take_bus_error(&mut self) -> Option<BusError> {
        self.bus_error.take()
    }

    /// A register's present value (reads have no side effects).
    pub fn peek(&self, offset: u32) -> u32 {
        let busy = self.busy.is_some();
        match offset & !3 {
            reg::ACR => self.acr,
            reg::SR => self.sr | if busy { sr::BSY } else { 0 },
            reg::CR => self.cr | if busy && self.erasing() { cr::STRT } else { 0 },
            reg::OPTCR => {
                let programming = matches!(self.busy, Some((_, Op::Options { .. })));
                self.optcr | if programming { optcr::OPTSTRT } else { 0 }
            }
            _ => 0,
        }
    }

    fn erasing(&self) -> bool {
        matches!(self.busy, Some((_, Op::Erase { .. })))
    }

    fn offset(&self, addr: u32, len: u32) -> Option<usize> {
        let off = addr.checked_sub(FLASH_BASE)? as usize;
        (off + len as usize <= FLASH_SIZE_BYTES).then_some(off)
    }

    /// Whether sector `n` is write-protected by the option bytes in effect (nWRP bit 0).
    fn protected(&self, n: u32) -> bool {
        self.options & (1 << (16 + n)) == 0
    }

    /// An error: its flag, and OPERR with ERRIE (RM0390 §3.8.4).
    fn error(&mut self, flag: u32) {
        self.sr |= flag;
        if self.cr & cr::ERRIE != 0 {
            self.sr |= sr::OPERR;
        }
    }

    /// A CPU write of `value` (`size` wide) to address `addr` of the array at `now`: a
    /// program access (RM0390 §3.5.4), or an error flag. Addresses outside the array are
    /// ignored.
    pub fn program(&mut self, addr: u32, size: Size, value: u32, now: Time) {
        self.advance(now, &Clocks::RESET);
        let Some(off) = self.offset(addr, size.bytes()) else {
            return;
        };
        // A write while busy waits (the bus stalls) for the operation under way.
        let start = match self.busy.take() {
            Some((end, op)) => {
                self.apply(op);
                end.max(now)
            }
            None => now,
        };
        if self.cr & cr::PG == 0 || self.cr & cr::LOCK != 0 {
            self.error(sr::PGSERR);
            return;
        }
        let psize_bytes = 1u32 << ((self.cr >> cr::PSIZE_SHIFT) & 3);
        if off / 16 != (off + size.bytes() as usize - 1) / 16 {
            self.error(sr::PGAERR);
            return;
        }
        if size.bytes() != psize_bytes {
            self.error(sr::PGPERR);
            return;
        }
        if self.protected(sector_of(off)) {
            self.error(sr::WRPERR);
            return;
        }
        let bytes = value.to_le_bytes()[..size.bytes() as usize].to_vec();
        self.busy = Some((start + PROGRAM_TIME, Op::Program { offset: off, bytes }));
    }

    /// STRT: a sector or mass erase.
    fn start_erase(&mut self) {
        let psize = (self.cr >> cr::PSIZE_SHIFT) & 3;
        let (ser, mer) = (self.cr & cr::SER != 0, self.cr & cr::MER != 0);
        let (offset, len, time) = if ser && mer {
            (0, 0, PROGRAM_TIME)
        } else if mer {
            if (0..8).any(|n| self.protected(n)) {
                self.error(sr::WRPERR);
                return;
            }
            (0, FLASH_SIZE_BYTES, erase_time(FLASH_SIZE_BYTES, psize))
        } else if ser {
            let snb = (self.cr >> cr::SNB_SHIFT) & 0xF;
            match sector_range(snb) {
                Some(_) if self.protected(snb) => {
                    self.error(sr::WRPERR);
                    return;
                }
                Some((offset, len)) => (offset, len, erase_time(len, psize)),
                // No such sector: nothing erased (not specified by RM0390).
                None => (0, 0, PROGRAM_TIME),
            }
        } else {
            // STRT with neither SER nor MER starts nothing.
            return;
        };
        self.busy = Some((self.now + time, Op::Erase { offset, len }));
    }

    /// An operation's result in the array, at its end.
    fn apply(&mut self, op: Op) {
        match op {
            Op::Program { offset, bytes } => {
                for (i, b) in bytes.into_iter().enumerate() {
                    self.array[offset + i] &= b;
                }
            }
            Op::Erase { offset, len } => self.array[offset..offset + len].fill(0xFF),
            Op::Options { value } => self.options = value,
        }
        if self.cr & cr::EOPIE != 0 {
            self.sr |= sr::EOP;
        }
    }

    fn key(&mut self, offset: u32, value: u32) {
        let (stage, locked_out, first, second) = if offset == reg::KEYR {
            (&mut self.key_stage, &mut self.cr_locked_out, KEY1, KEY2)
        } else {
            (
                &mut self.opt_key_stage,
                &mut self.optcr_locked_out,
                OPTKEY1,
                OPTKEY2,
            )
        };
        let unlocked = if offset == reg::KEYR {
            self.cr & cr::LOCK == 0
        } else {
            self.optcr & optcr::OPTLOCK == 0
        };
        let ok = !*locked_out
            && !unlocked
            && ((*stage == 0 && value == first) || (*stage == 1 && value == second));
        if !ok {
            *stage = 0;
            *locked_out = true;
            self.bus_error = Some(BusError { offset, value });
            return;
        }
        if *stage == 0 {
            *stage = 1;
        } else {
            *stage = 0;
            if offset == reg::KEYR {
                self.cr &= !cr::LOCK;
            } else {
                self.optcr &= !optcr::OPTLOCK;
            }
        }
    }
}

impl Peripheral for Flash {
    fn name(&self) -> &'static str {
        "FLASH"
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        lanes(self.peek(offset), offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        let word = offset & !3;
        let v = merge(self.peek(word), offset, size, value);
        match word {
            reg::ACR => self.acr = v & ACR_MASK,
            reg::KEYR | reg::OPTKEYR => self.key(word, v),
            reg::SR => self.sr &= !(v & sr::W1C),
            reg::CR => {
                if self.cr & cr::LOCK != 0 || self.busy.is_some() {
                    return;
                }
                self.cr = (v & cr::MASK) | (v & cr::LOCK);
                if v & cr::STRT != 0 && v & cr::LOCK == 0 {
                    self.start_erase();
                }
            }
            reg::OPTCR => {
                if self.optcr & optcr::OPTLOCK != 0 || self.busy.is_some() {
                    return;
                }
                self.optcr = (v & optcr::OPTIONS) | (v & optcr::OPTLOCK) | OPTCR_RESERVED;
                if v & optcr::OPTSTRT != 0 && v & optcr::OPTLOCK == 0 {
                    let value = self.optcr | (optcr::RESET & !optcr::OPTIONS);
                    self.busy = Some((self.now + OPTION_PROGRAM_TIME, Op::Options { value }));
                }
            }
            _ => {}
        }
    }

    fn advance(&mut self, now: Time, _clocks: &Clocks) {
        if self.busy.as_ref().is_some_and(|(t, _)| *t <= now) {
            if let Some((_, op)) = self.busy.take() {
                self.apply(op);
            }
        }
        self.now = self.now.max(now);
    }

    fn next_event(&self, now: Time, _clocks: &Clocks) -> Option<Time> {
        self.busy_until().map(|t| t.max(now))
    }
}

impl IrqLines for Flash {
    fn irqs(&self, line: &mut dyn FnMut(u16, bool)) {
        let eop = self.sr & sr::EOP != 0 && self.cr & cr::EOPIE != 0;
        let err = self.sr & sr::OPERR != 0 && self.cr & cr::ERRIE != 0;
        line(FLASH_IRQ, eop || err);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SECTOR6: u32 = FLASH_BASE + 0x4_0000;

    fn rd(f: &mut Flash, o: u32) -> u32 {
        f.read(o, Size::Word)
    }

    fn wr(f: &mut Flash, o: u32, v: u32) {
        f.write(o, Size::Word, v);
    }

    fn md(p: &mut Flash, o: u32, f: impl Fn(u32) -> u32) {
        let v = p.read(o, Size::Word);
        p.write(o, Size::Word, f(v));
    }

    fn unlock(f: &mut Flash) {
        wr(f, reg::KEYR, KEY1);
        wr(f, reg::KEYR, KEY2);
    }

    fn at(f: &mut Flash, t: Time) {
        f.advance(t, &Clocks::RESET);
    }

    #[test]
    fn reset_values_and_the_sector_map() {
        let mut f = Flash::new();
        assert_eq!(rd(&mut f, reg::ACR), 0);
        assert_eq!(rd(&mut f, reg::SR), 0);
        assert_eq!(rd(&mut f, reg::CR), 0x8000_0000);
        assert_eq!(rd(&mut f, reg::OPTCR), 0x0FFF_AAED);
        assert_eq!(sector_range(4), Some((0x1_0000, 0x1_0000)));
        assert_eq!(sector_range(5), Some((0x2_0000, 0x2_0000)));
        assert_eq!(sector_range(7), Some((0x6_0000, 0x2_0000)));
        assert_eq!(sector_of(0x3FFF), 0);
        assert_eq!(sector_of(0x4_0000), 6);
        assert!(f.array().iter().all(|b| *b == 0xFF));
        // Embassy's latency handshake: written, read back at once.
        wr(&mut f, reg::ACR, 5 | (7 << 8));
        assert_eq!(rd(&mut f, reg::ACR), 0x705);
    }

    #[test]
    fn unlock_takes_both_keys_and_a_wrong_key_locks_until_reset() {
        let mut f = Flash::new();
        wr(&mut f, reg::CR, cr::PG);
        assert_eq!(rd(&mut f, reg::CR), cr::LOCK, "locked: not writable");
        unlock(&mut f);
        assert_eq!(rd(&mut f, reg::CR), 0);
        assert_eq!(f.take_bus_error(), None);
        wr(&mut f, reg::CR, cr::LOCK);
        assert_eq!(rd(&mut f, reg::CR), cr::LOCK);
        wr(&mut f, reg::KEYR, KEY1);
        wr(&mut f, reg::KEYR, 0x1234_5678);
        assert_eq!(
            f.take_bus_error(),
            Some(BusError {
                offset: reg::KEYR,
                value: 0x1234_5678
            })
        );
        unlock(&mut f);
        assert_eq!(rd(&mut f, reg::CR), cr::LOCK, "locked until reset");
        f.reset();
        unlock(&mut f);
        assert_eq!(rd(&mut f, reg::CR), 0);
        // A key while unlocked is a wrong sequence too.
        wr(&mut f, reg::KEYR, KEY1);
        assert!(f.take_bus_error().is_some());
    }

    /// Embassy's blocking erase of sector 6 (SER, SNB, then STRT; PSIZE left at x8) and its
    /// word programming (PG with PSIZE x32, one word, wait BSY).
    #[test]
    fn erase_then_program_with_datasheet_timing() {
        let mut f = Flash::new();
        f.load(SECTOR6, &[0u8; 8]).unwrap();
        f.load(SECTOR6 + 0x1_FFFC, &[0x12, 0x34, 0x56, 0x78])
            .unwrap();
        f.load(SECTOR6 - 4, &[0; 4]).unwrap();
        f.load(SECTOR6 + 0x2_0000, &[0; 4]).unwrap();
        unlock(&mut f);
        let t0 = 1_000;
        at(&mut f, t0);
        wr(&mut f, reg::CR, cr::SER | (6 << cr::SNB_SHIFT) | cr::EOPIE);
        md(&mut f, reg::CR, |v| v | cr::STRT);
        assert_eq!(rd(&mut f, reg::SR), sr::BSY);
        assert_ne!(rd(&mut f, reg::CR) & cr::STRT, 0);
        let end = t0 + 2_000 * MILLISECOND; // 128 KiB at x8: 2 s.
        assert_eq!(f.busy_until(), Some(end));
        assert_eq!(f.next_event(t0, &Clocks::RESET), Some(end));
        at(&mut f, end - 1);
        assert_eq!(f.read_array(SECTOR6, Size::Word), Some(0), "not yet erased");
        at(&mut f, end);
        assert_eq!(rd(&mut f, reg::SR), sr::EOP);
        assert_eq!(rd(&mut f, reg::CR) & cr::STRT, 0);
        assert_eq!(f.read_array(SECTOR6, Size::Word), Some(0xFFFF_FFFF));
        assert_eq!(
            f.read_array(SECTOR6 + 0x1_FFFC, Size::Word),
            Some(0xFFFF_FFFF)
        );
        // Sectors 5 and 7 untouched.
        assert_eq!(f.read_array(SECTOR6 - 4, Size::Word), Some(0));
        assert_eq!(f.read_array(SECTOR6 + 0x2_0000, Size::Word), Some(0));
        let mut irq = false;
        f.irqs(&mut |n, high| {
            assert_eq!(n, FLASH_IRQ);
            irq = high;
        });
        assert!(irq);
        wr(&mut f, reg::SR, sr::EOP);
        assert_eq!(rd(&mut f, reg::SR), 0);
        // Program a word at x32.
        wr(&mut f, reg::CR, cr::PG | (2 << cr::PSIZE_SHIFT));
        f.program(SECTOR6 + 4, Size::Word, 0xA5A5_0F0F, end);
        assert_eq!(rd(&mut f, reg::SR), sr::BSY);
        at(&mut f, end + PROGRAM_TIME);
        assert_eq!(rd(&mut f, reg::SR), 0, "EOPIE clear: no EOP");
        assert_eq!(f.read_array(SECTOR6 + 4, Size::Word), Some(0xA5A5_0F0F));
        // Over a programmed word: only clears bits, no error.
        f.program(SECTOR6 + 4, Size::Word, 0xFF00_FFFF, end + PROGRAM_TIME);
        at(&mut f, end + 2 * PROGRAM_TIME);
        assert_eq!(rd(&mut f, reg::SR), 0);
        assert_eq!(f.read_array(SECTOR6 + 4, Size::Word), Some(0xA500_0F0F));
        assert_eq!(f.read_array(SECTOR6 + 5, Size::Byte), Some(0x0F));
    }

    #[test]
    fn erase_times_by_sector_size_and_psize() {
        for (snb, psize, ms) in [
            (0, 2, 250),
            (3, 1, 300),
            (4, 2, 550),
            (4, 0, 1_200),
            (7, 2, 1_000),
        ] {
            let mut f = Flash::new();
            unlock(&mut f);
            wr(
                &mut f,
                reg::CR,
                cr::SER | (snb << cr::SNB_SHIFT) | (psize << cr::PSIZE_SHIFT) | cr::STRT,
            );
            assert_eq!(f.busy_until(), Some(ms * MILLISECOND), "sector {snb}");
        }
    }

    #[test]
    fn programming_errors() {
        let mut f = Flash::new();
        f.program(SECTOR6, Size::Word, 0, 0);
        assert_eq!(rd(&mut f, reg::SR), sr::PGSERR, "locked, no PG");
        wr(&mut f, reg::SR, sr::W1C);
        unlock(&mut f);
        wr(&mut f, reg::CR, cr::PG | (2 << cr::PSIZE_SHIFT) | cr::ERRIE);
        f.program(SECTOR6, Size::Half, 0, 0);
        assert_eq!(rd(&mut f, reg::SR), sr::PGPERR | sr::OPERR);
        let mut irq = false;
        f.irqs(&mut |_, high| irq = high);
        assert!(irq);
        wr(&mut f, reg::SR, sr::W1C);
        f.program(SECTOR6 + 14, Size::Word, 0, 0);
        assert_eq!(
            rd(&mut f, reg::SR),
            sr::PGAERR | sr::OPERR,
            "crosses a 128-bit row"
        );
        wr(&mut f, reg::SR, sr::W1C);
        assert_eq!(
            f.read_array(SECTOR6, Size::Word),
            Some(0xFFFF_FFFF),
            "nothing written"
        );
        assert_eq!(f.busy_until(), None);
        // Write-protect sector 6 through the option bytes.
        wr(&mut f, reg::OPTKEYR, OPTKEY1);
        wr(&mut f, reg::OPTKEYR, OPTKEY2);
        assert_eq!(rd(&mut f, reg::OPTCR) & optcr::OPTLOCK, 0);
        let v = rd(&mut f, reg::OPTCR) & !(1 << 22);
        wr(&mut f, reg::OPTCR, v | optcr::OPTSTRT);
        assert_eq!(f.busy_until(), Some(OPTION_PROGRAM_TIME));
        assert_eq!(rd(&mut f, reg::OPTCR), 0x0FBF_AAEE, "OPTSTRT while busy");
        at(&mut f, OPTION_PROGRAM_TIME);
        f.program(SECTOR6, Size::Word, 0, OPTION_PROGRAM_TIME);
        assert_eq!(rd(&mut f, reg::SR) & sr::WRPERR, sr::WRPERR);
        wr(&mut f, reg::CR, cr::SER | (6 << cr::SNB_SHIFT) | cr::STRT);
        assert_eq!(f.busy_until(), None, "protected: no erase");
        f.reset();
        assert_eq!(
            rd(&mut f, reg::OPTCR),
            0x0FBF_AAED,
            "kept in the option bytes"
        );
    }

    /// A hand-made ELF: a flash segment, a RAM one (skipped), an empty one.
    #[test]
    fn elf_segments_load_at_their_load_addresses() {
        let mut elf = vec![0u8; 0x34 + 3 * 32 + 8];
        elf[..6].copy_from_slice(&[0x7F, b'E', b'L', b'F', 1, 1]);
        elf[0x1C..0x20].copy_from_slice(&0x34u32.to_le_bytes());
        elf[0x2A..0x2C].copy_from_slice(&32u16.to_le_bytes());
        elf[0x2C..0x2E].copy_from_slice(&3u16.to_le_bytes());
        let data = 0x34 + 3 * 32;
        elf[data..data + 8].copy_from_slice(&[1, 2, 3, 4, 5, 6, 7, 8]);
        for (i, (paddr, filesz)) in [
            (FLASH_BASE + 0x100, 8u32),
            (0x2000_0000, 8),
            (FLASH_BASE, 0),
        ]
        .into_iter()
        .enumerate()
        {
            let ph = 0x34 + i * 32;
            elf[ph..ph + 4].copy_from_slice(&1u32.to_le_bytes());
            elf[ph + 4..ph + 8].copy_from_slice(&(data as u32).to_le_bytes());
            elf[ph + 12..ph + 16].copy_from_slice(&paddr.to_le_bytes());
            elf[ph + 16..ph + 20].copy_from_slice(&filesz.to_le_bytes());
        }
        let mut f = Flash::new();
        assert_eq!(f.load_elf(&elf), Ok(8));
        assert_eq!(
            f.read_array(FLASH_BASE + 0x100, Size::Word),
            Some(0x0403_0201)
        );
        assert_eq!(f.array()[0x108], 0xFF);
        assert_eq!(f.read_array(FLASH_BASE, Size::Word), Some(0xFFFF_FFFF));
        assert!(f.load_elf(b"nope").is_err());
        elf[0x34 + 16..0x34 + 20].copy_from_slice(&64u32.to_le_bytes());
        assert!(f.load_elf(&elf).is_err(), "past the file's end");
    }

    #[test]
    fn ser_with_mer_erases_nothing_and_a_write_while_busy_waits() {
        let mut f = Flash::new();
        f.load(FLASH_BASE, &[0; 4]).unwrap();
        unlock(&mut f);
        wr(&mut f, reg::CR, cr::SER | cr::MER | cr::STRT);
        at(&mut f, PROGRAM_TIME);
        assert_eq!(f.read_array(FLASH_BASE, Size::Word), Some(0));
        wr(&mut f, reg::CR, cr::PG | (2 << cr::PSIZE_SHIFT));
        f.program(FLASH_BASE + 16, Size::Word, 0x1111_1111, PROGRAM_TIME);
        f.program(FLASH_BASE + 20, Size::Word, 0x2222_2222, PROGRAM_TIME + 1);
        assert_eq!(f.read_array(FLASH_BASE + 16, Size::Word), Some(0x1111_1111));
        assert_eq!(f.busy_until(), Some(3 * PROGRAM_TIME));
        // CR is not writable while busy.
        wr(&mut f, reg::CR, 0);
        assert_eq!(rd(&mut f, reg::CR), cr::PG | (2 << cr::PSIZE_SHIFT));
        assert!(f.load(FLASH_BASE + 0x7_FFFF, &[0, 0]).is_err());
    }
}
