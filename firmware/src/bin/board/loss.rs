//! Where console input lost bytes, as stream positions: the pure part of `serial` (no
//! hardware), so the host tests can check it.
//!
//! Positions count the bytes let into the receive ring since boot (wrapping). A loss "at p"
//! means bytes went missing just before accepted byte p.

/// The interrupt's decision for one received byte: `accepted` bytes let in so far, `taken` by
/// the reader, `overrun` the hardware's ORE flag, `capacity` the ring's size. Returns the new
/// `accepted` count and the position of a loss, if any: a full ring drops this byte (a loss
/// before the next accepted one); an overrun keeps this byte and lost what came after it.
pub fn on_receive(accepted: u32, taken: u32, overrun: bool, capacity: usize) -> (u32, Option<u32>) {
    if accepted.wrapping_sub(taken) as usize >= capacity {
        (accepted, Some(accepted))
    } else {
        let next = accepted.wrapping_add(1);
        (next, overrun.then_some(next))
    }
}

/// Merge a loss at `at` into the range of losses not yet handled (first, last).
pub fn merge(range: Option<(u32, u32)>, at: u32) -> Option<(u32, u32)> {
    Some(match range {
        Some((first, _)) => (first, at),
        None => (at, at),
    })
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

    /// A UART with a ring of `capacity` bytes: `input` arrives byte by byte; the reader empties
    /// the ring only at the byte indices in `reads` (and at the end); `overrun_at` are bytes
    /// after which the next byte is lost by the hardware. Returns each line's outcome.
    fn run(
        input: &[u8],
        capacity: usize,
        reads: &[usize],
        overrun_at: &[usize],
    ) -> Vec<Result<String, ConsoleError>> {
        let (mut accepted, mut taken) = (0u32, 0u32);
        let mut ring = VecDeque::new();
        let mut lost: Option<(u32, u32)> = None;
        let mut tracker = LossTracker::new();
        let mut reader: LineReader = LineReader::new();
        let mut out = Vec::new();
        let mut drain = |ring: &mut VecDeque<u8>,
                         lost: &mut Option<(u32, u32)>,
                         taken: &mut u32,
                         out: &mut Vec<_>| {
            let bytes: Vec<u8> = ring.drain(..).collect();
            *taken = taken.wrapping_add(bytes.len() as u32);
            tracker.add(lost.take());
            for b in bytes {
                if tracker.next_byte_lost() {
                    reader.mark_lost();
                }
                if let Some(l) = reader.push(b) {
                    out.push(l.map(String::from));
                }
            }
        };
        let mut i = 0;
        while i < input.len() {
            let overrun = overrun_at.contains(&i);
            let (next, loss) = on_receive(accepted, taken, overrun, capacity);
            if next != accepted {
                ring.push_back(input[i]);
            }
            accepted = next;
            if let Some(at) = loss {
                lost = merge(lost, at);
            }
            if overrun {
                i += 1; // the hardware lost the following byte
            }
            if reads.contains(&i) {
                drain(&mut ring, &mut lost, &mut taken, &mut out);
            }
            i += 1;
        }
        drain(&mut ring, &mut lost, &mut taken, &mut out);
        out
    }

    #[test]
    fn no_loss_no_marks() {
        let got = run(b"help\nstatus\n", 64, &[3, 9], &[]);
        assert_eq!(got, [Ok("help".into()), Ok("status".into())]);
    }

    #[test]
    fn a_full_ring_refuses_exactly_the_damaged_line() {
        // Ring of 8: the reader is away while `set target 358` arrives; bytes from the 9th on
        // are dropped until it reads, then the next lines are whole.
        let input = b"help\nset target 358\nstatus\n";
        let got = run(input, 8, &[4, 18], &[]);
        assert_eq!(
            got,
            [
                Ok("help".into()),
                Err(ConsoleError::LostBytes),
                Ok("status".into())
            ]
        );
    }

    #[test]
    fn an_overrun_refuses_the_line_it_hit() {
        // The `5` of 358 (index 17) is lost by the hardware: never `set target 38`.
        let input = b"help\nset target 358\nstatus\n";
        let got = run(input, 64, &[4, 20], &[16]);
        assert_eq!(
            got,
            [
                Ok("help".into()),
                Err(ConsoleError::LostBytes),
                Ok("status".into())
            ]
        );
        // A lost line end merges two lines into one refused line; the next is whole.
        let got = run(b"help\nversion\nstatus\n", 64, &[], &[3]);
        assert_eq!(got, [Err(ConsoleError::LostBytes), Ok("status".into())]);
    }

    #[test]
    fn losses_in_two_lines_refuse_both() {
        let input = b"help\nversion\nstatus\n";
        let got = run(input, 64, &[], &[1, 7]);
        assert_eq!(
            got,
            [
                Err(ConsoleError::LostBytes),
                Err(ConsoleError::LostBytes),
                Ok("status".into())
            ]
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
    }
}
