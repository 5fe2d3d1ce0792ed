//! SEGGER RTT's up channel 0 read out of the emulated chip's RAM as a debug probe reads it: the
//! bytes between the channel's read and write offsets, then the read offset advanced in the
//! chip's memory, so the target sees them taken.
//!
//! The control block (`_SEGGER_RTT`, 32-bit little-endian): the id `"SEGGER RTT\0"` in 16
//! bytes, the numbers of up and down channels (two `i32`), then the up channels' descriptors of
//! six words each — the name's address, the ring buffer's address, its size, the write offset
//! (the target's), the read offset (the host's) and the flags (the mode in bits 0–1). The ring
//! is empty when the two offsets are equal and holds `write − read` bytes modulo its size
//! otherwise.
//!
//! The board's logger (`defmt-rtt` 1.3) starts the channel in its non-blocking mode (flags 1)
//! and blocks when the ring is full only if a probe sets the mode to 2, which this reader does
//! not: the board runs as on a bench with no probe attached. In that mode defmt-rtt writes
//! without looking at the read offset, so a host that falls behind by a whole ring (1024 bytes
//! by default) loses what was written over; the harness reads often enough (every millisecond
//! of the chip's time, and just before a chip reset) that what the board logs cannot lap it.

use super::Memory;

/// The control block's id, its first 11 bytes (the rest of its 16 are zero on the board).
pub const ID: &[u8; 11] = b"SEGGER RTT\0";

/// Where up channel 0's descriptor starts in the control block.
const UP0: u32 = 24;

/// Why the up channel cannot be read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RttError {
    /// The control block has no RTT id yet: the target's start-up code has not initialised its
    /// data (or the address is not a control block).
    #[error("no RTT control block at {0:#010x} (not initialised yet?)")]
    NoControlBlock(u32),
    /// The control block's memory cannot be read (outside the chip's RAM and flash).
    #[error("the RTT control block at {0:#010x} cannot be read")]
    Unreadable(u32),
    /// The block has an id but no usable up channel 0: no up channel, a ring outside memory or
    /// offsets beyond its size (a corrupted block).
    #[error(
        "RTT up channel 0 is unusable: {up} up channels, ring at {buffer:#010x} of {size} bytes, \
         write offset {write}, read offset {read}"
    )]
    BadChannel {
        /// The number of up channels the block declares.
        up: i32,
        /// The ring's address.
        buffer: u32,
        /// The ring's size, bytes.
        size: u32,
        /// The write offset.
        write: u32,
        /// The read offset.
        read: u32,
    },
}

/// A reader of up channel 0 of the RTT control block at one address.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RttUp {
    block: u32,
}

impl RttUp {
    /// A reader of the control block at `block` (the ELF's `_SEGGER_RTT`).
    pub fn new(block: u32) -> RttUp {
        RttUp { block }
    }

    /// The control block's address.
    pub fn block(&self) -> u32 {
        self.block
    }

    /// Take what the target wrote since the last read: append the bytes between the read and
    /// the write offset to `out` (the older part first when they wrap around the ring's end)
    /// and set the read offset to the write offset in `mem`. Returns how many bytes were taken
    /// (0: nothing new).
    pub fn drain(&self, mem: &mut dyn Memory, out: &mut Vec<u8>) -> Result<usize, RttError> {
        let mut head = [0u8; (UP0 + 24) as usize];
        if !mem.read(self.block, &mut head) {
            return Err(RttError::Unreadable(self.block));
        }
        if &head[..ID.len()] != ID {
            return Err(RttError::NoControlBlock(self.block));
        }
        let word = |at: u32| {
            let at = at as usize;
            u32::from_le_bytes([head[at], head[at + 1], head[at + 2], head[at + 3]])
        };
        let up = word(16) as i32;
        let buffer = word(UP0 + 4);
        let size = word(UP0 + 8);
        let write = word(UP0 + 12);
        let read = word(UP0 + 16);
        let bad = RttError::BadChannel {
            up,
            buffer,
            size,
            write,
            read,
        };
        if up < 1 || size == 0 || write >= size || read >= size {
            return Err(bad);
        }
        if write == read {
            return Ok(0);
        }
        let start = out.len();
        let mut take = |from: u32, to: u32, out: &mut Vec<u8>| -> bool {
            let at = out.len();
            out.resize(at + (to - from) as usize, 0);
            buffer
                .checked_add(from)
                .is_some_and(|a| mem.read(a, &mut out[at..]))
        };
        let ok = if write > read {
            take(read, write, out)
        } else {
            take(read, size, out) && take(0, write, out)
        };
        if !ok {
            out.truncate(start);
            return Err(bad);
        }
        if !mem.write(self.block + UP0 + 16, &write.to_le_bytes()) {
            out.truncate(start);
            return Err(RttError::Unreadable(self.block));
        }
        Ok(out.len() - start)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Memory at 0x2000_0000: a control block at its start, a 16-byte ring at 0x100.
    struct Ram(Vec<u8>);

    const BASE: u32 = 0x2000_0000;
    const RING: u32 = BASE + 0x100;
    const SIZE: u32 = 16;

    impl Memory for Ram {
        fn read(&mut self, addr: u32, buf: &mut [u8]) -> bool {
            let Some(at) = addr.checked_sub(BASE).map(|a| a as usize) else {
                return false;
            };
            match self.0.get(at..at + buf.len()) {
                Some(b) => {
                    buf.copy_from_slice(b);
                    true
                }
                None => false,
            }
        }

        fn write(&mut self, addr: u32, bytes: &[u8]) -> bool {
            let Some(at) = addr.checked_sub(BASE).map(|a| a as usize) else {
                return false;
            };
            match self.0.get_mut(at..at + bytes.len()) {
                Some(b) => {
                    b.copy_from_slice(bytes);
                    true
                }
                None => false,
            }
        }
    }

    impl Ram {
        fn put(&mut self, at: u32, v: u32) {
            self.write(at, &v.to_le_bytes());
        }

        fn word(&mut self, at: u32) -> u32 {
            let mut b = [0; 4];
            assert!(self.read(at, &mut b));
            u32::from_le_bytes(b)
        }

        /// A block as defmt-rtt's start-up data makes it (one up channel, non-blocking).
        fn initialised() -> Ram {
            let mut r = Ram(vec![0; 0x200]);
            r.write(BASE, b"SEGGER RTT\0\0\0\0\0\0");
            r.put(BASE + 16, 1);
            r.put(BASE + 20, 0);
            r.put(BASE + UP0 + 4, RING);
            r.put(BASE + UP0 + 8, SIZE);
            r.put(BASE + UP0 + 20, 1);
            r
        }

        /// The target's side: write `bytes` at its write offset (wrapping), as defmt-rtt does.
        fn log(&mut self, bytes: &[u8]) {
            let mut w = self.word(BASE + UP0 + 12);
            for &b in bytes {
                self.write(RING + w, &[b]);
                w = (w + 1) % SIZE;
            }
            self.put(BASE + UP0 + 12, w);
        }
    }

    #[test]
    fn bytes_are_taken_in_order_across_the_rings_end_and_the_read_offset_follows() {
        let mut ram = Ram::initialised();
        let rtt = RttUp::new(BASE);
        let mut out = Vec::new();
        assert_eq!(rtt.drain(&mut ram, &mut out), Ok(0), "an empty ring");
        ram.log(b"0123456789");
        assert_eq!(rtt.drain(&mut ram, &mut out), Ok(10));
        assert_eq!(out, b"0123456789");
        assert_eq!(ram.word(BASE + UP0 + 16), 10, "the read offset follows");
        // 9 more: 6 to the ring's end, 3 from its start.
        ram.log(b"abcdefghi");
        assert_eq!(ram.word(BASE + UP0 + 12), 3, "the target wrapped");
        out.clear();
        assert_eq!(rtt.drain(&mut ram, &mut out), Ok(9));
        assert_eq!(out, b"abcdefghi", "the older part first");
        assert_eq!(ram.word(BASE + UP0 + 16), 3);
        assert_eq!(rtt.drain(&mut ram, &mut out), Ok(0), "nothing new");
        assert_eq!(out, b"abcdefghi");
        // A full ring (size − 1 bytes) read in one go.
        ram.log(b"ABCDEFGHIJKLMNO");
        out.clear();
        assert_eq!(rtt.drain(&mut ram, &mut out), Ok(15));
        assert_eq!(out, b"ABCDEFGHIJKLMNO");
    }

    #[test]
    fn a_block_not_yet_initialised_or_corrupted_is_refused_and_left_alone() {
        let rtt = RttUp::new(BASE);
        let mut out = Vec::new();
        let mut zeros = Ram(vec![0; 0x200]);
        assert_eq!(
            rtt.drain(&mut zeros, &mut out),
            Err(RttError::NoControlBlock(BASE))
        );
        assert_eq!(
            RttUp::new(0x1000).drain(&mut zeros, &mut out),
            Err(RttError::Unreadable(0x1000))
        );
        // A write offset beyond the ring.
        let mut ram = Ram::initialised();
        ram.put(BASE + UP0 + 12, SIZE);
        let err = rtt.drain(&mut ram, &mut out).unwrap_err();
        assert!(
            matches!(err, RttError::BadChannel { write: 16, .. }),
            "{err}"
        );
        assert_eq!(ram.word(BASE + UP0 + 16), 0, "the read offset untouched");
        // A ring outside memory.
        let mut ram = Ram::initialised();
        ram.put(BASE + UP0 + 4, 0x3000_0000);
        ram.log(b"xy");
        assert!(matches!(
            rtt.drain(&mut ram, &mut out),
            Err(RttError::BadChannel { .. })
        ));
        assert_eq!(ram.word(BASE + UP0 + 16), 0);
        // No up channel.
        let mut ram = Ram::initialised();
        ram.put(BASE + 16, 0);
        assert!(matches!(
            rtt.drain(&mut ram, &mut out),
            Err(RttError::BadChannel { up: 0, .. })
        ));
        assert!(out.is_empty(), "nothing taken from a bad block");
    }

    /// A chip reset re-initialises the block (both offsets 0): what follows is read from the
    /// ring's start.
    #[test]
    fn after_the_target_reinitialises_the_block_reading_starts_over() {
        let mut ram = Ram::initialised();
        let rtt = RttUp::new(BASE);
        let mut out = Vec::new();
        ram.log(b"before");
        rtt.drain(&mut ram, &mut out).unwrap();
        ram.put(BASE + UP0 + 12, 0);
        ram.put(BASE + UP0 + 16, 0);
        ram.log(b"after");
        out.clear();
        assert_eq!(rtt.drain(&mut ram, &mut out), Ok(5));
        assert_eq!(out, b"after");
    }
}
