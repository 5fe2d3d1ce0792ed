//! Where console input lost or damaged bytes, as stream positions: the pure part of `serial`
//! (no hardware), so the host tests can check it.
//!
//! Positions count the bytes let into the receive ring since boot (wrapping). A loss "at p"
//! marks the line that byte p is in: bytes went missing just before byte p, or byte p itself
//! arrived damaged.

/// What the USART's status register said when its interrupt ran (SR, read before embassy's
/// handler reads the data register, which clears the flags).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RxStatus {
    /// RXNE: a byte waits in the data register; embassy's handler takes it.
    pub received: bool,
    /// ORE: a byte arrived while the data register was still full, and was lost.
    pub overrun: bool,
    /// FE, NF or PE: the waiting byte had a framing error (or was a break), noise on its bits,
    /// or a parity error. embassy only logs these and keeps the byte, so it is counted as lost.
    pub damaged: bool,
}

/// The interrupt's and the reader's counts, kept together so each side updates them in one
/// critical section.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Watch {
    /// Bytes let into the ring since boot (wrapping), as far as the interrupt can tell.
    accepted: u32,
    /// Bytes the reader took out of the ring since boot (wrapping).
    taken: u32,
    /// Losses not yet handed to the reader: the first and the last position.
    lost: Option<(u32, u32)>,
}

impl Watch {
    /// Nothing received yet.
    pub const fn new() -> Self {
        Watch {
            accepted: 0,
            taken: 0,
            lost: None,
        }
    }

    /// One interrupt's status, with a ring of `capacity` bytes. A byte that meets a full ring
    /// is dropped by embassy (a loss before the next accepted byte); a damaged byte is let in
    /// and is itself the loss; an overrun lost a byte after the one waiting (or, with none
    /// waiting, after the last one let in).
    pub fn on_interrupt(&mut self, sr: RxStatus, capacity: usize) {
        let at = self.accepted;
        if !sr.received {
            if sr.overrun {
                self.lose(at, at);
            }
        } else if at.wrapping_sub(self.taken) as usize >= capacity {
            self.lose(at, at);
        } else {
            let next = at.wrapping_add(1);
            self.accepted = next;
            match (sr.damaged, sr.overrun) {
                (true, true) => self.lose(at, next),
                (true, false) => self.lose(at, at),
                (false, true) => self.lose(next, next),
                (false, false) => {}
            }
        }
    }

    /// The reader took `n` more bytes out of the ring: return the losses recorded since the
    /// last call (for [`LossTracker::add`]).
    ///
    /// If the reader has now taken more than the interrupt counted, the count missed bytes (a
    /// byte that reached the data register between this watch's look at SR and embassy's, or
    /// one embassy let into a ring that had just been emptied but not yet counted as such) and
    /// is set to the reader's: a count left behind would make every later byte look like one
    /// meeting a full ring, recorded at a position the reader has already passed, so no later
    /// loss would ever be marked.
    pub fn took(&mut self, n: usize) -> Option<(u32, u32)> {
        self.taken = self.taken.wrapping_add(n as u32);
        if (self.accepted.wrapping_sub(self.taken) as i32) < 0 {
            self.accepted = self.taken;
        }
        self.lost.take()
    }

    fn lose(&mut self, first: u32, last: u32) {
        self.lost = Some(match self.lost {
            Some((a, _)) => (a, last),
            None => (first, last),
        });
    }
}

/// The reader's side: where it is in the stream and which positions lost bytes.
pub struct LossTracker {
    pos: u32,
    pending: Option<(u32, u32)>,
}

impl LossTracker {
    /// A tracker at the start of the stream.
    pub const fn new() -> Self {
        LossTracker {
            pos: 0,
            pending: None,
        }
    }

    /// Add the losses the interrupt recorded since the last call.
    pub fn add(&mut self, losses: Option<(u32, u32)>) {
        if let Some((a, b)) = losses {
            self.pending = Some(match self.pending {
                Some((first, _)) => (first, b),
                None => (a, b),
            });
        }
    }

    /// Advance past the next byte; return whether bytes were lost just before it (or between
    /// two losses), so its line must be marked lost.
    pub fn next_byte_lost(&mut self) -> bool {
        let pos = self.pos;
        self.pos = pos.wrapping_add(1);
        match self.pending {
            // Positions wrap after 4 GiB: compare distances, not values.
            Some((a, b)) if pos.wrapping_sub(a) <= b.wrapping_sub(a) => {
                if pos == b {
                    self.pending = None;
                }
                true
            }
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;
    use std::string::String;
    use std::vec::Vec;
    use thermorph::console::{ConsoleError, LineReader};

    /// What happens to one input byte on the wire.
    #[derive(Clone, Copy, PartialEq)]
    enum Fate {
        /// The hardware loses the byte after this one (an overrun).
        OverrunAfter,
        /// The byte arrives with a framing, noise or parity error.
        Damaged,
        /// The byte is lost by an overrun noticed only after the data register was emptied
        /// (ORE without RXNE).
        LostLate,
        /// The byte reaches the data register just after the watch looked at SR: embassy takes
        /// it, the watch never counts it.
        Unseen,
    }

    /// A UART with embassy's ring of `capacity` bytes: `input` arrives byte by byte; the reader
    /// empties the ring only after the byte indices in `reads` (and at the end); `fates` says
    /// what goes wrong with which byte. Returns each line's outcome.
    fn run(
        input: &[u8],
        capacity: usize,
        reads: &[usize],
        fates: &[(usize, Fate)],
    ) -> Vec<Result<String, ConsoleError>> {
        let mut watch = Watch::new();
        let mut ring = VecDeque::new();
        let mut tracker = LossTracker::new();
        let mut reader: LineReader = LineReader::new();
        let mut out = Vec::new();
        let mut drain = |ring: &mut VecDeque<u8>, watch: &mut Watch, out: &mut Vec<_>| {
            let bytes: Vec<u8> = ring.drain(..).collect();
            tracker.add(watch.took(bytes.len()));
            for b in bytes {
                if tracker.next_byte_lost() {
                    reader.mark_lost();
                }
                if let Some(l) = reader.push(b) {
                    out.push(l.map(String::from));
                }
            }
        };
        let fate = |i: usize| fates.iter().find(|f| f.0 == i).map(|f| f.1);
        let mut i = 0;
        while i < input.len() {
            let f = fate(i);
            if f == Some(Fate::LostLate) {
                watch.on_interrupt(
                    RxStatus {
                        overrun: true,
                        ..RxStatus::default()
                    },
                    capacity,
                );
            } else {
                let sr = RxStatus {
                    received: f != Some(Fate::Unseen),
                    overrun: f == Some(Fate::OverrunAfter),
                    damaged: f == Some(Fate::Damaged),
                };
                watch.on_interrupt(sr, capacity);
                // embassy's handler: the byte goes in if the ring has room (damaged or not).
                if ring.len() < capacity {
                    ring.push_back(input[i]);
                }
                if sr.overrun {
                    i += 1; // the hardware lost the following byte
                }
            }
            if reads.contains(&i) {
                drain(&mut ring, &mut watch, &mut out);
            }
            i += 1;
        }
        drain(&mut ring, &mut watch, &mut out);
        out
    }

    fn lines(v: &[Option<&str>]) -> Vec<Result<String, ConsoleError>> {
        v.iter()
            .map(|l| l.map(String::from).ok_or(ConsoleError::LostBytes))
            .collect()
    }

    #[test]
    fn no_loss_no_marks() {
        let got = run(b"help\nstatus\n", 64, &[3, 9], &[]);
        assert_eq!(got, lines(&[Some("help"), Some("status")]));
    }

    #[test]
    fn a_full_ring_refuses_exactly_the_damaged_line() {
        // Ring of 8: the reader is away while `set target 358` arrives; bytes from the 9th on
        // are dropped until it reads, then the next lines are whole.
        let input = b"help\nset target 358\nstatus\n";
        let got = run(input, 8, &[4, 18], &[]);
        assert_eq!(got, lines(&[Some("help"), None, Some("status")]));
    }

    #[test]
    fn an_overrun_refuses_the_line_it_hit() {
        // The `5` of 358 (index 17) is lost by the hardware: never `set target 38`.
        let input = b"help\nset target 358\nstatus\n";
        let got = run(input, 64, &[4, 20], &[(16, Fate::OverrunAfter)]);
        assert_eq!(got, lines(&[Some("help"), None, Some("status")]));
        // Noticed only after the data register was read: the same.
        let got = run(input, 64, &[4, 20], &[(17, Fate::LostLate)]);
        assert_eq!(got, lines(&[Some("help"), None, Some("status")]));
        // A lost line end merges two lines into one refused line; the next is whole.
        let got = run(
            b"help\nversion\nstatus\n",
            64,
            &[],
            &[(3, Fate::OverrunAfter)],
        );
        assert_eq!(got, lines(&[None, Some("status")]));
    }

    #[test]
    fn a_damaged_byte_refuses_its_line() {
        let input = b"help\nset target 358\nstatus\n";
        // Framing or noise error on the `5`: the byte is in the ring, but the line is refused.
        let got = run(input, 64, &[4, 20], &[(17, Fate::Damaged)]);
        assert_eq!(got, lines(&[Some("help"), None, Some("status")]));
        // On the line end: that line is refused, the next is whole.
        let got = run(input, 64, &[], &[(4, Fate::Damaged)]);
        assert_eq!(got, lines(&[None, Some("set target 358"), Some("status")]));
        // On the first byte of a line, right after a read: that line, not the one before.
        let got = run(input, 64, &[4], &[(5, Fate::Damaged)]);
        assert_eq!(got, lines(&[Some("help"), None, Some("status")]));
        // Damaged and followed by an overrun: the byte and the one after it.
        let damaged = |overrun: bool| {
            let mut w = Watch::new();
            let sr = RxStatus {
                received: true,
                overrun,
                damaged: true,
            };
            w.on_interrupt(sr, 64);
            w.took(1)
        };
        assert_eq!(damaged(true), Some((0, 1)));
        assert_eq!(damaged(false), Some((0, 0)));
    }

    #[test]
    fn losses_in_two_lines_refuse_both() {
        let input = b"help\nversion\nstatus\n";
        let fates = [(1, Fate::OverrunAfter), (7, Fate::OverrunAfter)];
        let got = run(input, 64, &[], &fates);
        assert_eq!(got, lines(&[None, None, Some("status")]));
    }

    #[test]
    fn a_byte_the_watch_missed_does_not_blind_it() {
        // The watch misses byte 1: without the resync its count stays one behind the reader's,
        // every later byte looks like one meeting a full ring, at a position the reader has
        // passed, and no later loss is ever marked.
        let input = b"help\nversion\nstatus\nhelp\n";
        let fates = [(1, Fate::Unseen), (15, Fate::Damaged)];
        let got = run(input, 8, &[2, 4, 12, 19, 24], &fates);
        assert_eq!(
            got,
            lines(&[Some("help"), Some("version"), None, Some("help")])
        );
    }

    #[test]
    fn positions_wrap() {
        let mut t = LossTracker {
            pos: u32::MAX,
            pending: None,
        };
        t.add(Some((u32::MAX, 0)));
        assert!(t.next_byte_lost());
        assert!(t.next_byte_lost());
        assert!(!t.next_byte_lost());

        let mut w = Watch {
            accepted: u32::MAX,
            taken: u32::MAX,
            lost: None,
        };
        let sr = RxStatus {
            received: true,
            ..RxStatus::default()
        };
        w.on_interrupt(sr, 2);
        w.on_interrupt(sr, 2);
        w.on_interrupt(sr, 2); // the ring is full: dropped
        assert_eq!(w.took(2), Some((1, 1)));
        assert_eq!(w.accepted, 1);
    }
}
