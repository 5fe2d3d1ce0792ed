//! DMA1 and DMA2, the STM32F446's two general-purpose DMA controllers (RM0390 §9): their
//! register windows (LISR/HISR, LIFCR/HIFCR, and per stream CR, NDTR, PAR, M0AR, M1AR, FCR),
//! the streams' transfers and their interrupt lines.
//!
//! What this model owns: the registers and what a stream does when it is serviced — one
//! request moves one data item (a burst of them with PBURST in FIFO mode) between the
//! peripheral's address and memory through [`DmaBus`], increments the addresses, decrements
//! NDTR, sets HTIF at half and TCIF at the end, reloads in circular mode, toggles CT in double
//! buffer mode, sets TEIF and disables the stream on a bus error, and clears EN at the end of a
//! non-circular transfer. What it does not own: which peripheral's request reaches which
//! stream (the chip's request mapping, RM0390 tables 28/29: it compares [`Dma::channel`] with
//! the peripheral's channel and calls [`Dma::service`] while the request is high) and the
//! arbitration between streams (the chip services them in the order it likes; PL is stored and
//! reported by [`Dma::priority`]), nor the end-of-transfer signals a stream gives its
//! peripheral (the chip passes them on from [`Serviced::Moved`]'s `remaining`: NDTR 1 on
//! I2C1_RX is the I2C's EOT−1, `I2c::dma_eot_1`; NDTR 0 on ADC1's stream is `Adc::dma_eot`).
//!
//! Modelling choices (RM0390 §9.3):
//! - An item moves at once when serviced: the AHB cycles a transfer takes are not timed (a few
//!   bus cycles, far below the I2C's 22 µs a byte or the ADC's 44 µs a conversion).
//! - Direct mode (DMDIS=0, what embassy-stm32 programs for the I2C's bytes and the ADC's half
//!   words, equal sizes) moves each item straight through with MSIZE taken as PSIZE, as the
//!   manual says. FIFO mode (DMDIS=1) keeps a 16-byte FIFO that packs and unpacks between PSIZE
//!   and MSIZE; as items move at once it can neither overrun nor underrun, so FEIF is never set
//!   by a transfer. FTH is stored: it decides when the chip's FIFO drains to memory, which with
//!   items moving at once changes nothing the software can see but FS. FS reports the FIFO's
//!   fill level (100: empty, always so in direct mode, as after reset).
//! - DMEIF is never set: a direct-mode item always completes before the peripheral's next
//!   request, so the "request while the previous item is pending" error cannot happen.
//! - PFCTRL (the SDIO's flow control) is stored but the F446 models here have no flow
//!   controller: the stream counts with NDTR as if PFCTRL were 0. The board never sets it.
//! - Memory-to-memory (DIR=10) runs when serviced, without a request: the chip calls
//!   [`Dma::service`] while [`Dma::memory_to_memory_pending`] says so.
//! - Disabling a stream (EN written 0) while items remain sets TCIF, as §9.3.17 says; EN reads
//!   0 at once (no item is ever half moved here).
//! - Registers other than CR.EN (and FCR.FEIE, and M0AR/M1AR of the memory not in use in double
//!   buffer mode) are protected while EN=1: writes to them are ignored (§9.5).

use super::{IrqLines, Peripheral, Size};

/// What a DMA stream's bus access failed on: the address decodes to nothing, or the target
/// refused the access (the chip's bus matrix answers this; RM0390 §9.3.16 "transfer error").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BusFault;

/// The chip's buses as a DMA stream sees them: reads and writes at addresses (peripheral
/// registers, SRAM, flash), implemented by the chip.
pub trait DmaBus {
    /// Read `size` at `address` (the value in the low bits).
    fn read(&mut self, address: u32, size: Size) -> Result<u32, BusFault>;
    /// Write `value` (`size` wide, in its low bits) at `address`.
    fn write(&mut self, address: u32, size: Size, value: u32) -> Result<(), BusFault>;
}

/// Which of the two controllers (their bases and interrupt lines differ).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Controller {
    /// DMA1 at 0x4002_6000 (stream IRQs 11–17, 47).
    Dma1,
    /// DMA2 at 0x4002_6400 (stream IRQs 56–60, 68–70).
    Dma2,
}

impl Controller {
    /// The register window's base address.
    pub const fn base(self) -> u32 {
        match self {
            Controller::Dma1 => 0x4002_6000,
            Controller::Dma2 => 0x4002_6400,
        }
    }

    /// The NVIC position of stream `stream`'s interrupt (RM0390 table 38).
    pub const fn irq(self, stream: usize) -> u16 {
        match (self, stream) {
            (Controller::Dma1, 0..=6) => 11 + stream as u16,
            (Controller::Dma1, _) => 47,
            (Controller::Dma2, 0..=4) => 56 + stream as u16,
            (Controller::Dma2, _) => 68 + (stream as u16 - 5),
        }
    }
}

/// The flags of a stream in LISR/HISR (at the stream's offset there).
pub mod flag {
    /// FIFO error.
    pub const FEIF: u32 = 1 << 0;
    /// Direct mode error.
    pub const DMEIF: u32 = 1 << 2;
    /// Transfer error.
    pub const TEIF: u32 = 1 << 3;
    /// Half transfer.
    pub const HTIF: u32 = 1 << 4;
    /// Transfer complete.
    pub const TCIF: u32 = 1 << 5;
    /// All of them.
    pub const ALL: u32 = FEIF | DMEIF | TEIF | HTIF | TCIF;
}

/// SxCR's bits (RM0390 §9.5.5).
pub mod cr {
    /// Stream enable.
    pub const EN: u32 = 1 << 0;
    /// Direct mode error interrupt enable.
    pub const DMEIE: u32 = 1 << 1;
    /// Transfer error interrupt enable.
    pub const TEIE: u32 = 1 << 2;
    /// Half transfer interrupt enable.
    pub const HTIE: u32 = 1 << 3;
    /// Transfer complete interrupt enable.
    pub const TCIE: u32 = 1 << 4;
    /// Peripheral flow controller.
    pub const PFCTRL: u32 = 1 << 5;
    /// Direction's shift (2 bits: 00 peripheral-to-memory, 01 memory-to-peripheral, 10
    /// memory-to-memory).
    pub const DIR_SHIFT: u32 = 6;
    /// Circular mode.
    pub const CIRC: u32 = 1 << 8;
    /// Peripheral increment.
    pub const PINC: u32 = 1 << 9;
    /// Memory increment.
    pub const MINC: u32 = 1 << 10;
    /// Peripheral data size's shift (2 bits: 00 byte, 01 half word, 10 word).
    pub const PSIZE_SHIFT: u32 = 11;
    /// Memory data size's shift (2 bits).
    pub const MSIZE_SHIFT: u32 = 13;
    /// Peripheral increment offset size (1: by 4 whatever PSIZE).
    pub const PINCOS: u32 = 1 << 15;
    /// Priority level's shift (2 bits).
    pub const PL_SHIFT: u32 = 16;
    /// Double buffer mode.
    pub const DBM: u32 = 1 << 18;
    /// Current target (0: M0AR, 1: M1AR).
    pub const CT: u32 = 1 << 19;
    /// Peripheral burst's shift (2 bits: single, INCR4, INCR8, INCR16).
    pub const PBURST_SHIFT: u32 = 21;
    /// Memory burst's shift (2 bits).
    pub const MBURST_SHIFT: u32 = 23;
    /// Channel selection's shift (3 bits).
    pub const CHSEL_SHIFT: u32 = 25;
    /// The bits that exist (bit 20 and 28–31 are reserved).
    pub const MASK: u32 = 0x0FEF_FFFF;
}

/// SxFCR's bits (RM0390 §9.5.10).
pub mod fcr {
    /// FIFO threshold's mask (2 bits).
    pub const FTH: u32 = 0b11;
    /// Direct mode disable (1: FIFO mode).
    pub const DMDIS: u32 = 1 << 2;
    /// FIFO status's shift (3 bits, read-only).
    pub const FS_SHIFT: u32 = 3;
    /// FIFO error interrupt enable.
    pub const FEIE: u32 = 1 << 7;
}

/// What servicing a stream did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Serviced {
    /// The stream is disabled: nothing moved.
    Idle,
    /// Items moved; `remaining` is NDTR after them (0: the transfer's end; in circular mode
    /// NDTR has already been reloaded, and `remaining` is still 0 for that request).
    Moved {
        /// NDTR after the request (before a circular reload).
        remaining: u16,
    },
    /// A bus error: TEIF set, the stream disabled.
    Error,
}

/// One stream's registers and its transfer's internal state.
#[derive(Clone, Debug, Default)]
struct Stream {
    cr: u32,
    ndtr: u16,
    par: u32,
    m0ar: u32,
    m1ar: u32,
    /// FCR's FTH, DMDIS and FEIE (FS is computed).
    fcr: u32,
    /// NDTR as programmed at the enable (the circular reload).
    reload: u16,
    /// The peripheral and memory pointers of the transfer in progress.
    p_ptr: u32,
    m_ptr: u32,
    /// FIFO mode's bytes, oldest first.
    fifo: Vec<u8>,
}

impl Stream {
    fn field(&self, shift: u32, bits: u32) -> u32 {
        (self.cr >> shift) & ((1 << bits) - 1)
    }

    fn dir(&self) -> u32 {
        self.field(cr::DIR_SHIFT, 2)
    }

    fn direct(&self) -> bool {
        self.fcr & fcr::DMDIS == 0
    }

    fn psize(&self) -> Size {
        size_of_field(self.field(cr::PSIZE_SHIFT, 2))
    }

    fn msize(&self) -> Size {
        if self.direct() {
            self.psize()
        } else {
            size_of_field(self.field(cr::MSIZE_SHIFT, 2))
        }
    }

    fn enabled(&self) -> bool {
        self.cr & cr::EN != 0
    }

    fn fcr_read(&self) -> u32 {
        let fs = if self.direct() {
            0b100
        } else {
            match self.fifo.len() {
                0 => 0b100,
                n if n >= 16 => 0b101,
                n => (n * 4 / 16) as u32,
            }
        };
        self.fcr | fs << fcr::FS_SHIFT
    }

    fn mem_base(&self) -> u32 {
        if self.cr & cr::CT != 0 {
            self.m1ar
        } else {
            self.m0ar
        }
    }

    fn start(&mut self) {
        self.reload = self.ndtr;
        self.p_ptr = self.par;
        self.m_ptr = self.mem_base();
        self.fifo.clear();
    }
}

fn size_of_field(v: u32) -> Size {
    match v {
        0 => Size::Byte,
        1 => Size::Half,
        // 11 is reserved; the model takes it as a word.
        _ => Size::Word,
    }
}

fn bytes_of(value: u32, size: Size) -> impl Iterator<Item = u8> {
    (0..size.bytes()).map(move |i| (value >> (8 * i)) as u8)
}

/// A DMA controller (DMA1 or DMA2): eight streams, their registers and transfers.
#[derive(Clone, Debug)]
pub struct Dma {
    controller: Controller,
    /// LISR (streams 0–3) and HISR (4–7).
    isr: [u32; 2],
    streams: [Stream; 8],
}

/// A stream's flags' offset in its LISR/HISR word.
const fn flag_shift(stream: usize) -> u32 {
    [0, 6, 16, 22][stream % 4]
}

impl Dma {
    /// The controller after reset: every stream disabled, registers at their reset values
    /// (FCR 0x21: direct mode, FIFO threshold half, FIFO empty).
    pub fn new(controller: Controller) -> Self {
        let stream = Stream {
            fcr: 0x01,
            ..Stream::default()
        };
        Dma {
            controller,
            isr: [0; 2],
            streams: core::array::from_fn(|_| stream.clone()),
        }
    }

    /// The RCC's reset of the controller (AHB1RSTR DMAxRST): the reset state.
    pub fn rcc_reset(&mut self) {
        *self = Dma::new(self.controller);
    }

    /// Which controller this is.
    pub fn controller(&self) -> Controller {
        self.controller
    }

    /// Stream `stream`'s flags (the [`flag`] bits).
    pub fn flags(&self, stream: usize) -> u32 {
        (self.isr[stream / 4] >> flag_shift(stream)) & flag::ALL
    }

    fn set_flags(&mut self, stream: usize, bits: u32) {
        self.isr[stream / 4] |= bits << flag_shift(stream);
    }

    /// Whether stream `stream` is enabled (EN).
    pub fn enabled(&self, stream: usize) -> bool {
        self.streams[stream].enabled()
    }

    /// The channel stream `stream` selects (CHSEL, 0–7): which peripheral request feeds it.
    pub fn channel(&self, stream: usize) -> u8 {
        self.streams[stream].field(cr::CHSEL_SHIFT, 3) as u8
    }

    /// Stream `stream`'s priority level (PL, 0 low … 3 very high).
    pub fn priority(&self, stream: usize) -> u8 {
        self.streams[stream].field(cr::PL_SHIFT, 2) as u8
    }

    /// NDTR of stream `stream` (items left).
    pub fn remaining(&self, stream: usize) -> u16 {
        self.streams[stream].ndtr
    }

    /// Whether stream `stream` is an enabled memory-to-memory transfer (which runs without a
    /// request: the chip services it until it ends).
    pub fn memory_to_memory_pending(&self, stream: usize) -> bool {
        let s = &self.streams[stream];
        s.enabled() && s.dir() == 0b10
    }

    /// Service one request of stream `stream`: if enabled, move one item (a burst of PBURST
    /// items in FIFO mode) through `bus`, then update NDTR, the pointers and the flags.
    pub fn service(&mut self, stream: usize, bus: &mut dyn DmaBus) -> Serviced {
        let s = &self.streams[stream];
        if !s.enabled() || (s.ndtr == 0 && s.cr & (cr::CIRC | cr::DBM) == 0) {
            // §9.5.6: with NDTR 0 no transaction is served, even with the stream enabled.
            return Serviced::Idle;
        }
        let items = {
            let s = &self.streams[stream];
            if s.direct() {
                1
            } else {
                [1, 4, 8, 16][s.field(cr::PBURST_SHIFT, 2) as usize]
            }
        };
        let mut remaining = self.streams[stream].ndtr;
        for _ in 0..items {
            match self.move_item(stream, bus) {
                Ok(r) => remaining = r,
                Err(BusFault) => {
                    self.set_flags(stream, flag::TEIF);
                    self.streams[stream].cr &= !cr::EN;
                    return Serviced::Error;
                }
            }
            if !self.streams[stream].enabled() || remaining == 0 {
                break;
            }
        }
        Serviced::Moved { remaining }
    }

    /// Move one peripheral-size item; returns NDTR after it (0 at the end, before a reload).
    fn move_item(&mut self, stream: usize, bus: &mut dyn DmaBus) -> Result<u16, BusFault> {
        let s = &mut self.streams[stream];
        if s.ndtr == 0 {
            return Ok(0);
        }
        let (psize, msize) = (s.psize(), s.msize());
        let p_step = if s.cr & cr::PINC == 0 {
            0
        } else if s.cr & cr::PINCOS != 0 {
            4
        } else {
            psize.bytes()
        };
        let m_step = if s.cr & cr::MINC != 0 {
            msize.bytes()
        } else {
            0
        };
        match s.dir() {
            0b00 => {
                // Peripheral to memory: read the peripheral, pack into memory items.
                let v = bus.read(s.p_ptr, psize)?;
                s.p_ptr = s.p_ptr.wrapping_add(p_step);
                s.fifo.extend(bytes_of(v, psize));
                while s.fifo.len() >= msize.bytes() as usize {
                    let v = take(&mut s.fifo, msize);
                    bus.write(s.m_ptr, msize, v)?;
                    s.m_ptr = s.m_ptr.wrapping_add(m_step);
                }
            }
            dir => {
                // Memory to peripheral (01) and memory to memory (10: PAR is the source, M0AR
                // the destination, RM0390 §9.3.6): fill from the source, write the other side.
                let (src_size, dst_size) = if dir == 0b01 {
                    (msize, psize)
                } else {
                    (psize, msize)
                };
                while s.fifo.len() < dst_size.bytes() as usize {
                    if dir == 0b01 {
                        let v = bus.read(s.m_ptr, src_size)?;
                        s.m_ptr = s.m_ptr.wrapping_add(m_step);
                        s.fifo.extend(bytes_of(v, src_size));
                    } else {
                        let v = bus.read(s.p_ptr, src_size)?;
                        s.p_ptr = s.p_ptr.wrapping_add(p_step);
                        s.fifo.extend(bytes_of(v, src_size));
                    }
                }
                let v = take(&mut s.fifo, dst_size);
                if dir == 0b01 {
                    bus.write(s.p_ptr, dst_size, v)?;
                    s.p_ptr = s.p_ptr.wrapping_add(p_step);
                } else {
                    bus.write(s.m_ptr, dst_size, v)?;
                    s.m_ptr = s.m_ptr.wrapping_add(m_step);
                }
            }
        }
        s.ndtr -= 1;
        let remaining = s.ndtr;
        let mut flags = 0;
        if remaining == s.reload / 2 {
            flags |= flag::HTIF;
        }
        if remaining == 0 {
            flags |= flag::TCIF;
            // Double buffer mode implies circular (RM0390 §9.3.10).
            if s.cr & (cr::CIRC | cr::DBM) != 0 && s.dir() != 0b10 {
                if s.cr & cr::DBM != 0 {
                    s.cr ^= cr::CT;
                }
                s.ndtr = s.reload;
                s.p_ptr = s.par;
                s.m_ptr = s.mem_base();
            } else {
                s.cr &= !cr::EN;
            }
        }
        self.set_flags(stream, flags);
        Ok(remaining)
    }

    fn write_stream(&mut self, stream: usize, reg: u32, value: u32) {
        let s = &mut self.streams[stream];
        let enabled = s.enabled();
        match reg {
            0x00 => {
                let value = value & cr::MASK;
                if enabled {
                    // Only EN is writable while enabled (CT is a status then).
                    if value & cr::EN == 0 {
                        s.cr &= !cr::EN;
                        if s.ndtr != 0 {
                            // §9.3.17: a stream disabled mid-transfer reports TCIF.
                            self.set_flags(stream, flag::TCIF);
                        }
                    }
                } else {
                    s.cr = value;
                    if value & cr::EN != 0 {
                        if s.direct() {
                            // §9.5.5: in direct mode MSIZE takes PSIZE's value and the bursts
                            // are forced to single as EN is set.
                            let psize = s.field(cr::PSIZE_SHIFT, 2);
                            s.cr &= !(0b11 << cr::MSIZE_SHIFT
                                | 0b11 << cr::PBURST_SHIFT
                                | 0b11 << cr::MBURST_SHIFT);
                            s.cr |= psize << cr::MSIZE_SHIFT;
                        }
                        s.start();
                    }
                }
            }
            0x04 if !enabled => s.ndtr = value as u16,
            0x08 if !enabled => s.par = value,
            0x0C if !enabled || (s.cr & cr::DBM != 0 && s.cr & cr::CT != 0) => s.m0ar = value,
            0x10 if !enabled || (s.cr & cr::DBM != 0 && s.cr & cr::CT == 0) => s.m1ar = value,
            0x14 => {
                let writable = if enabled {
                    fcr::FEIE
                } else {
                    fcr::FEIE | fcr::DMDIS | fcr::FTH
                };
                s.fcr = (s.fcr & !writable) | (value & writable);
            }
            // Protected while enabled.
            _ => {}
        }
    }

    fn read_word(&self, offset: u32) -> u32 {
        match offset {
            0x00 => self.isr[0],
            0x04 => self.isr[1],
            // The clear registers read as 0.
            0x08 | 0x0C => 0,
            0x10..=0xCC => {
                let stream = ((offset - 0x10) / 0x18) as usize;
                let s = &self.streams[stream];
                match (offset - 0x10) % 0x18 {
                    0x00 => s.cr,
                    0x04 => u32::from(s.ndtr),
                    0x08 => s.par,
                    0x0C => s.m0ar,
                    0x10 => s.m1ar,
                    _ => s.fcr_read(),
                }
            }
            _ => 0,
        }
    }
}

fn take(fifo: &mut Vec<u8>, size: Size) -> u32 {
    let n = size.bytes() as usize;
    let v = fifo[..n]
        .iter()
        .rev()
        .fold(0u32, |acc, &b| acc << 8 | u32::from(b));
    fifo.drain(..n);
    v
}

impl Peripheral for Dma {
    fn name(&self) -> &'static str {
        match self.controller {
            Controller::Dma1 => "DMA1",
            Controller::Dma2 => "DMA2",
        }
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        super::lanes(self.read_word(offset & !3), offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        let word = offset & !3;
        // The clear registers and the stream registers take the lanes written; other lanes
        // of a narrow write keep their present value.
        let old = self.read_word(word);
        let value = super::merge(old, offset, size, value);
        match word {
            0x08 | 0x0C => {
                // LIFCR/HIFCR: 1 clears the flag at the same position; only the written lanes.
                let lanes = super::merge(0, offset, size, u32::MAX);
                self.isr[(word as usize - 0x08) / 4] &= !(value & lanes);
            }
            0x10..=0xCC => {
                let stream = ((word - 0x10) / 0x18) as usize;
                self.write_stream(stream, (word - 0x10) % 0x18, value);
            }
            // LISR/HISR are read-only.
            _ => {}
        }
    }
}

impl IrqLines for Dma {
    fn irqs(&self, line: &mut dyn FnMut(u16, bool)) {
        for (n, s) in self.streams.iter().enumerate() {
            let f = self.flags(n);
            let high = (f & flag::TCIF != 0 && s.cr & cr::TCIE != 0)
                || (f & flag::HTIF != 0 && s.cr & cr::HTIE != 0)
                || (f & flag::TEIF != 0 && s.cr & cr::TEIE != 0)
                || (f & flag::DMEIF != 0 && s.cr & cr::DMEIE != 0)
                || (f & flag::FEIF != 0 && s.fcr & fcr::FEIE != 0);
            line(self.controller.irq(n), high);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// A byte-addressed memory with a fault window and a log of peripheral accesses.
    #[derive(Default)]
    struct Mem {
        bytes: BTreeMap<u32, u8>,
        /// Accesses at or above this address fail.
        fault_from: Option<u32>,
        log: Vec<(char, u32, Size, u32)>,
    }

    impl DmaBus for Mem {
        fn read(&mut self, address: u32, size: Size) -> Result<u32, BusFault> {
            if self.fault_from.is_some_and(|f| address >= f) {
                return Err(BusFault);
            }
            let v = (0..size.bytes()).rev().fold(0u32, |acc, i| {
                acc << 8 | u32::from(*self.bytes.get(&(address + i)).unwrap_or(&0))
            });
            self.log.push(('r', address, size, v));
            Ok(v)
        }
        fn write(&mut self, address: u32, size: Size, value: u32) -> Result<(), BusFault> {
            if self.fault_from.is_some_and(|f| address >= f) {
                return Err(BusFault);
            }
            for i in 0..size.bytes() {
                self.bytes.insert(address + i, (value >> (8 * i)) as u8);
            }
            self.log.push(('w', address, size, value));
            Ok(())
        }
    }

    const S6: u32 = 0x10 + 0x18 * 6;
    const S0: u32 = 0x10;
    const DR: u32 = 0x4000_5410;

    fn word(dma: &mut Dma, offset: u32) -> u32 {
        dma.read(offset, Size::Word)
    }

    fn lines(dma: &Dma) -> Vec<(u16, bool)> {
        let mut v = Vec::new();
        dma.irqs(&mut |irq, high| v.push((irq, high)));
        v
    }

    /// Program stream `base` as embassy-stm32 does (PAR, M0AR, NDTR, FCR, CR without EN,
    /// then EN).
    fn configure(dma: &mut Dma, base: u32, par: u32, mar: u32, n: u32, cr_bits: u32) {
        dma.write(base + 0x08, Size::Word, par);
        dma.write(base + 0x0C, Size::Word, mar);
        dma.write(base + 0x04, Size::Word, n);
        dma.write(base + 0x14, Size::Word, 0); // direct mode
        dma.write(base, Size::Word, cr_bits);
        dma.write(base, Size::Word, cr_bits | cr::EN);
    }

    #[test]
    fn memory_to_peripheral_bytes_increment_memory_only_and_end_with_tc() {
        let mut dma = Dma::new(Controller::Dma1);
        let mut mem = Mem::default();
        for (i, b) in [0x80u8, 0x0D, 0x55].iter().enumerate() {
            mem.bytes.insert(0x2000_0100 + i as u32, *b);
        }
        // DMA1 stream 6 channel 1 (I2C1_TX): M2P, MINC, bytes, TEIE|TCIE, PL very high.
        let bits = 1 << cr::CHSEL_SHIFT
            | 0b11 << cr::PL_SHIFT
            | cr::MINC
            | 0b01 << cr::DIR_SHIFT
            | cr::TCIE
            | cr::TEIE;
        configure(&mut dma, S6, DR, 0x2000_0100, 3, bits);
        assert!(dma.enabled(6));
        assert_eq!(dma.channel(6), 1);
        assert_eq!(dma.priority(6), 3);
        assert_eq!(dma.service(6, &mut mem), Serviced::Moved { remaining: 2 });
        assert_eq!(word(&mut dma, S6 + 4), 2);
        // PAR and M0AR keep their programmed values (the pointers are internal).
        assert_eq!(word(&mut dma, S6 + 0x0C), 0x2000_0100);
        dma.service(6, &mut mem);
        assert_eq!(dma.service(6, &mut mem), Serviced::Moved { remaining: 0 });
        let writes: Vec<_> = mem.log.iter().filter(|e| e.0 == 'w').cloned().collect();
        assert_eq!(
            writes,
            vec![
                ('w', DR, Size::Byte, 0x80),
                ('w', DR, Size::Byte, 0x0D),
                ('w', DR, Size::Byte, 0x55)
            ]
        );
        // HISR: stream 6's flags at bit 16; TC and HT (after item 2 of 3: NDTR 1 = 3/2).
        assert_eq!(word(&mut dma, 0x04), (flag::TCIF | flag::HTIF) << 16);
        assert!(
            !dma.enabled(6),
            "EN cleared at the end of a non-circular transfer"
        );
        assert_eq!(dma.service(6, &mut mem), Serviced::Idle);
        assert!(lines(&dma).contains(&(17, true)));
        // HIFCR clears TC: the line drops (HTIE is off, so HT does not hold it).
        dma.write(0x0C, Size::Word, flag::TCIF << 16);
        assert_eq!(word(&mut dma, 0x04), flag::HTIF << 16);
        assert!(lines(&dma).contains(&(17, false)));
        dma.write(0x0C, Size::Word, flag::ALL << 16);
        assert_eq!(word(&mut dma, 0x04), 0);
    }

    #[test]
    fn peripheral_to_memory_half_words_circular_with_ht_tc_and_reload() {
        // DMA2 stream 0 channel 0 (ADC1): P2M, MINC, half words, circular, HTIE|TCIE.
        let mut dma = Dma::new(Controller::Dma2);
        let mut mem = Mem::default();
        let adc_dr = 0x4001_204C;
        let bits = 0b01 << cr::PSIZE_SHIFT
            | 0b01 << cr::MSIZE_SHIFT
            | cr::MINC
            | cr::CIRC
            | cr::HTIE
            | cr::TCIE
            | cr::TEIE;
        configure(&mut dma, S0, adc_dr, 0x2000_0000, 4, bits);
        let mut codes = 100u32..;
        let mut step = |dma: &mut Dma, mem: &mut Mem| {
            let c = codes.next().unwrap();
            mem.bytes.insert(adc_dr, c as u8);
            mem.bytes.insert(adc_dr + 1, (c >> 8) as u8);
            dma.service(0, mem)
        };
        step(&mut dma, &mut mem);
        assert_eq!(dma.flags(0), 0);
        assert_eq!(step(&mut dma, &mut mem), Serviced::Moved { remaining: 2 });
        assert_eq!(dma.flags(0), flag::HTIF);
        assert!(lines(&dma).contains(&(56, true)));
        dma.write(0x08, Size::Word, flag::HTIF);
        assert!(lines(&dma).contains(&(56, false)));
        step(&mut dma, &mut mem);
        assert_eq!(step(&mut dma, &mut mem), Serviced::Moved { remaining: 0 });
        assert_eq!(dma.flags(0), flag::TCIF);
        assert!(dma.enabled(0), "circular: stays enabled");
        assert_eq!(word(&mut dma, S0 + 4), 4, "NDTR reloaded");
        // The fifth item lands at the buffer's start again.
        step(&mut dma, &mut mem);
        let half = |a: u32| u32::from(mem.bytes[&a]) | u32::from(mem.bytes[&(a + 1)]) << 8;
        assert_eq!(half(0x2000_0000), 104);
        assert_eq!(half(0x2000_0002), 101);
        assert_eq!(half(0x2000_0006), 103);
        // The peripheral address never moved (PINC=0).
        assert!(mem.log.iter().filter(|e| e.0 == 'r').all(|e| e.1 == adc_dr));
    }

    #[test]
    fn protected_registers_ignore_writes_while_enabled_and_disable_sets_tc() {
        let mut dma = Dma::new(Controller::Dma1);
        assert_eq!(word(&mut dma, S0 + 0x14), 0x21, "FCR reset value");
        // Direct mode: MSIZE (word here) takes PSIZE's value (byte) at the enable.
        configure(
            &mut dma,
            S0,
            DR,
            0x2000_0000,
            5,
            cr::MINC | 0b10 << cr::MSIZE_SHIFT,
        );
        assert_eq!(word(&mut dma, S0) >> cr::MSIZE_SHIFT & 3, 0);
        dma.write(S0 + 4, Size::Word, 99);
        dma.write(S0 + 8, Size::Word, 0x1234);
        dma.write(S0, Size::Word, cr::EN | cr::CIRC);
        assert_eq!(word(&mut dma, S0 + 4), 5);
        assert_eq!(word(&mut dma, S0 + 8), DR);
        assert_eq!(word(&mut dma, S0), cr::MINC | cr::EN);
        // Disabled mid-transfer: EN reads 0, TCIF set; then the registers are writable.
        dma.write(S0, Size::Word, cr::MINC);
        assert!(!dma.enabled(0));
        assert_eq!(dma.flags(0), flag::TCIF);
        dma.write(S0 + 4, Size::Word, 7);
        assert_eq!(word(&mut dma, S0 + 4), 7);
        // A byte write to NDTR changes its low lane only.
        dma.write(S0 + 4, Size::Byte, 0x03);
        assert_eq!(word(&mut dma, S0 + 4), 3);
        // Enabled with NDTR 0: nothing is served, EN stays.
        let mut mem = Mem::default();
        dma.write(S0 + 4, Size::Word, 0);
        dma.write(0x08, Size::Word, flag::ALL);
        dma.write(S0, Size::Word, cr::MINC | cr::EN);
        assert_eq!(dma.service(0, &mut mem), Serviced::Idle);
        assert!(dma.enabled(0));
        assert!(mem.log.is_empty());
        dma.rcc_reset();
        assert!(!dma.enabled(0));
        assert_eq!(word(&mut dma, S0 + 0x14), 0x21);
    }

    #[test]
    fn bus_error_sets_te_and_disables() {
        let mut dma = Dma::new(Controller::Dma1);
        let mut mem = Mem {
            fault_from: Some(0x6000_0000),
            ..Mem::default()
        };
        configure(
            &mut dma,
            S0 + 0x18 * 7,
            DR,
            0x6000_0000,
            2,
            0b01 << cr::DIR_SHIFT | cr::MINC | cr::TEIE,
        );
        assert_eq!(dma.service(7, &mut mem), Serviced::Error);
        assert_eq!(dma.flags(7), flag::TEIF);
        assert!(!dma.enabled(7));
        assert_eq!(word(&mut dma, S0 + 0x18 * 7 + 4), 2, "nothing moved");
        assert!(lines(&dma).contains(&(47, true)));
    }

    #[test]
    fn double_buffer_toggles_ct_and_switches_memory() {
        let mut dma = Dma::new(Controller::Dma2);
        let mut mem = Mem::default();
        dma.write(S0 + 0x10, Size::Word, 0x2000_0100);
        configure(
            &mut dma,
            S0,
            DR,
            0x2000_0000,
            2,
            cr::DBM | cr::MINC | cr::TCIE,
        );
        for _ in 0..2 {
            dma.service(0, &mut mem);
        }
        assert_eq!(word(&mut dma, S0) & cr::CT, cr::CT);
        // M0AR is not in use now: writable while enabled; M1AR is protected.
        dma.write(S0 + 0x0C, Size::Word, 0x2000_0200);
        dma.write(S0 + 0x10, Size::Word, 0x2000_0300);
        assert_eq!(word(&mut dma, S0 + 0x0C), 0x2000_0200);
        assert_eq!(word(&mut dma, S0 + 0x10), 0x2000_0100);
        dma.service(0, &mut mem);
        assert_eq!(mem.log.last().unwrap().1, 0x2000_0100);
        dma.service(0, &mut mem);
        dma.service(0, &mut mem);
        assert_eq!(mem.log.last().unwrap().1, 0x2000_0200, "the new M0AR");
    }

    #[test]
    fn fifo_mode_packs_bytes_into_words_and_bursts() {
        let mut dma = Dma::new(Controller::Dma2);
        let mut mem = Mem::default();
        for i in 0..8u32 {
            mem.bytes.insert(0x4000_0000 + i, 0x10 + i as u8);
        }
        dma.write(S0 + 0x08, Size::Word, 0x4000_0000);
        dma.write(S0 + 0x0C, Size::Word, 0x2000_0000);
        dma.write(S0 + 0x04, Size::Word, 8);
        dma.write(S0 + 0x14, Size::Word, fcr::DMDIS | 0b11);
        // Bytes from an incrementing peripheral address, words to memory, INCR4 bursts.
        let bits = cr::PINC | 0b10 << cr::MSIZE_SHIFT | cr::MINC | 0b01 << cr::PBURST_SHIFT;
        dma.write(S0, Size::Word, bits | cr::EN);
        assert_eq!(dma.service(0, &mut mem), Serviced::Moved { remaining: 4 });
        assert_eq!(dma.service(0, &mut mem), Serviced::Moved { remaining: 0 });
        let words: Vec<_> = mem.log.iter().filter(|e| e.0 == 'w').cloned().collect();
        assert_eq!(
            words,
            vec![
                ('w', 0x2000_0000, Size::Word, 0x1312_1110),
                ('w', 0x2000_0004, Size::Word, 0x1716_1514)
            ]
        );
        assert_eq!(word(&mut dma, S0 + 0x14) >> fcr::FS_SHIFT & 7, 0b100);
    }

    #[test]
    fn memory_to_memory_runs_without_request() {
        let mut dma = Dma::new(Controller::Dma2);
        let mut mem = Mem::default();
        mem.bytes.insert(0x2000_0000, 0xAA);
        mem.bytes.insert(0x2000_0001, 0xBB);
        dma.write(S0 + 0x08, Size::Word, 0x2000_0000);
        dma.write(S0 + 0x0C, Size::Word, 0x2000_0100);
        dma.write(S0 + 0x04, Size::Word, 2);
        dma.write(S0 + 0x14, Size::Word, fcr::DMDIS);
        dma.write(
            S0,
            Size::Word,
            0b10 << cr::DIR_SHIFT | cr::PINC | cr::MINC | cr::EN,
        );
        while dma.memory_to_memory_pending(0) {
            dma.service(0, &mut mem);
        }
        assert_eq!(mem.bytes[&0x2000_0100], 0xAA);
        assert_eq!(mem.bytes[&0x2000_0101], 0xBB);
        assert_eq!(dma.flags(0), flag::TCIF | flag::HTIF);
    }

    #[test]
    fn flag_positions_in_lisr_hisr_and_pincos() {
        let mut dma = Dma::new(Controller::Dma1);
        let mut mem = Mem::default();
        // Stream 3 (LISR bits 22–27) and stream 5 (HISR bits 6–11), one item each.
        for (stream, shift, isr) in [(3usize, 22u32, 0x00u32), (5, 6, 0x04)] {
            let base = 0x10 + 0x18 * stream as u32;
            configure(&mut dma, base, 0x4000_0000, 0x2000_0000, 1, cr::TCIE);
            dma.service(stream, &mut mem);
            assert_eq!(word(&mut dma, isr), (flag::TCIF | flag::HTIF) << shift);
            // A half-word write to the clear register's half clears it.
            let ifcr = isr + 0x08;
            let half = shift / 16 * 2;
            dma.write(ifcr + half, Size::Half, (flag::ALL << shift) >> (8 * half));
            assert_eq!(word(&mut dma, isr), 0);
        }
        // PINCOS: the peripheral address steps by 4 whatever PSIZE (bytes here).
        let mut mem = Mem::default();
        configure(
            &mut dma,
            S0,
            0x4000_0000,
            0x2000_0000,
            3,
            cr::PINC | cr::PINCOS | cr::MINC,
        );
        for _ in 0..3 {
            dma.service(0, &mut mem);
        }
        let reads: Vec<u32> = mem.log.iter().filter(|e| e.0 == 'r').map(|e| e.1).collect();
        assert_eq!(reads, [0x4000_0000, 0x4000_0004, 0x4000_0008]);
        let writes: Vec<u32> = mem.log.iter().filter(|e| e.0 == 'w').map(|e| e.1).collect();
        assert_eq!(writes, [0x2000_0000, 0x2000_0001, 0x2000_0002]);
    }

    #[test]
    fn irq_numbers_follow_table_38() {
        let d1: Vec<_> = (0..8).map(|s| Controller::Dma1.irq(s)).collect();
        let d2: Vec<_> = (0..8).map(|s| Controller::Dma2.irq(s)).collect();
        assert_eq!(d1, [11, 12, 13, 14, 15, 16, 17, 47]);
        assert_eq!(d2, [56, 57, 58, 59, 60, 68, 69, 70]);
    }
}
