//! The virtual MLX90640 (`sensor::virtual_mlx`) as a target on the emulated I2C1: the bytes
//! the chip's master shifts become the device's transactions (a 2-byte write sets its
//! register pointer, a 4-byte write writes a word, reads return words big-endian from the
//! pointer on), at the chip's time, which the chip gives the device's clock before each
//! advance ([`MlxTarget::set_time`]).

use std::cell::RefCell;
use std::rc::Rc;

use embedded_hal::i2c::Operation;

use super::i2c::I2cTarget;
use super::{TIME_HZ, Time};
use crate::sensor::sim_time::SimClock;
use crate::sensor::virtual_mlx::{SensorFault, VirtualMlx90640};

/// The virtual sensor on the emulated bus.
pub struct MlxTarget {
    device: Rc<RefCell<VirtualMlx90640>>,
    clock: SimClock,
    /// Bytes written since the START.
    written: Vec<u8>,
    /// The register pointer (None: not set since the last word write).
    pointer: Option<u16>,
    /// The word being read and which of its bytes comes next.
    word: [u8; 2],
    half: usize,
    /// The present transaction's address was acknowledged.
    addressed: bool,
    /// Transactions the device refused (a write it does not take, a read without a pointer).
    refused: u64,
}

impl MlxTarget {
    /// The device on the bus, `clock` its clock (the one it was built with).
    pub fn new(device: Rc<RefCell<VirtualMlx90640>>, clock: SimClock) -> MlxTarget {
        MlxTarget {
            device,
            clock,
            written: Vec::new(),
            pointer: None,
            word: [0; 2],
            half: 0,
            addressed: false,
            refused: 0,
        }
    }

    /// Bring the device's clock to the chip's time `now` (it never goes back).
    pub fn set_time(&self, now: Time) {
        let us = u128::from(now) * 1_000_000 / u128::from(TIME_HZ);
        let us = us as u64;
        let at = self.clock.now_us();
        if us > at {
            self.clock.advance_us(us - at);
        }
    }

    /// Transactions the device refused so far.
    pub fn refused(&self) -> u64 {
        self.refused
    }

    /// The written bytes as the device's operation: the pointer, or a word written.
    fn flush(&mut self) {
        let w = core::mem::take(&mut self.written);
        match w.len() {
            0 => {}
            2 => self.pointer = Some(u16::from_be_bytes([w[0], w[1]])),
            4 => {
                let buf = w;
                let r = self
                    .device
                    .borrow_mut()
                    .transact(thermorph::mlx90640::ADDRESS, &mut [Operation::Write(&buf)]);
                self.pointer = None;
                if r.is_err() {
                    self.refused += 1;
                }
            }
            _ => self.refused += 1,
        }
    }

    /// The word at the pointer, read from the device.
    fn fetch(&mut self) -> [u8; 2] {
        let Some(ptr) = self.pointer else {
            self.refused += 1;
            return [0xFF; 2];
        };
        let at = ptr.to_be_bytes();
        let mut word = [0u8; 2];
        let r = self.device.borrow_mut().transact(
            thermorph::mlx90640::ADDRESS,
            &mut [Operation::Write(&at), Operation::Read(&mut word)],
        );
        if r.is_err() {
            self.refused += 1;
            return [0xFF; 2];
        }
        word
    }
}

impl I2cTarget for MlxTarget {
    fn start(&mut self, address: u8, _read: bool) -> bool {
        self.flush();
        self.half = 0;
        // The device answers its address unless it is faulted to NACK.
        self.addressed = address == thermorph::mlx90640::ADDRESS
            && self.device.borrow().fault() != Some(SensorFault::Nack);
        self.addressed
    }

    fn write(&mut self, byte: u8) -> bool {
        self.written.push(byte);
        self.addressed && self.written.len() <= 4
    }

    fn read(&mut self, _ack: bool) -> u8 {
        if self.half == 0 {
            self.word = self.fetch();
        }
        let b = self.word[self.half];
        self.half ^= 1;
        if self.half == 0 {
            self.pointer = self.pointer.map(|p| p.wrapping_add(1));
        }
        b
    }

    fn stop(&mut self) {
        self.flush();
        self.half = 0;
        self.addressed = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::eeprom;

    fn target() -> (MlxTarget, Rc<RefCell<VirtualMlx90640>>) {
        let clock = SimClock::new();
        let words = eeprom::realistic(1).encode().unwrap();
        let dev = VirtualMlx90640::new(words, clock.clone(), 1).unwrap();
        let dev = Rc::new(RefCell::new(dev));
        (MlxTarget::new(dev.clone(), clock), dev)
    }

    /// Read `n` words at `addr` as the chip's master does: write the pointer, repeated START,
    /// read.
    fn read_words(t: &mut MlxTarget, addr: u16, n: usize) -> Vec<u16> {
        assert!(t.start(0x33, false));
        for b in addr.to_be_bytes() {
            assert!(t.write(b));
        }
        assert!(t.start(0x33, true));
        let out = (0..n)
            .map(|i| {
                let hi = t.read(true);
                let lo = t.read(i + 1 < n);
                u16::from_be_bytes([hi, lo])
            })
            .collect();
        t.stop();
        out
    }

    #[test]
    fn words_read_over_the_bus_are_the_devices() {
        let (mut t, dev) = target();
        // The EEPROM's first words and the control register, as the device holds them.
        let words = read_words(&mut t, 0x2400, 4);
        let ee = eeprom::realistic(1).encode().unwrap();
        assert_eq!(words, ee[..4].to_vec());
        let ctrl = read_words(&mut t, 0x800D, 1)[0];
        assert_eq!(ctrl, dev.borrow().control().0);
        // A word write: the control register (refresh 4 Hz).
        assert!(t.start(0x33, false));
        for b in [0x80, 0x0D, 0x19, 0x81] {
            assert!(t.write(b));
        }
        t.stop();
        assert_eq!(dev.borrow().control().0, 0x1981);
        assert_eq!(t.refused(), 0);
    }

    #[test]
    fn another_address_and_a_nack_fault_are_not_acknowledged() {
        let (mut t, dev) = target();
        assert!(!t.start(0x34, false));
        t.stop();
        dev.borrow_mut().set_fault(Some(SensorFault::Nack));
        assert!(!t.start(0x33, false));
    }

    #[test]
    fn the_chip_time_runs_the_devices_measurements() {
        let (t, dev) = target();
        let before = dev.borrow().measurements();
        // Two seconds at the power-on 2 Hz: measurements are due; a read runs them.
        t.set_time(2 * TIME_HZ);
        let mut t = t;
        let _ = read_words(&mut t, 0x8000, 1);
        assert!(dev.borrow().measurements() > before);
    }
}
