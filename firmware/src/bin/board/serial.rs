//! Console input that never loses a byte silently.
//!
//! embassy's buffered UART drops a byte when its receive ring is full and only logs a hardware
//! overrun. [`RxLossWatch`] runs in the USART2 interrupt just before embassy's handler and
//! records where in the byte stream bytes went missing: it counts the bytes let into the ring,
//! and the console reader ([`LossTracker`]) counts the bytes it took out. A byte arriving with
//! [`RX_BUF`] bytes already waiting is dropped by embassy: a loss before the next byte; an
//! overrun (ORE: a byte came while the previous one was still in the data register) loses the
//! bytes after the one being taken. The reader marks the line those positions fall in as lost
//! ([`thermorph::console::LineReader::mark_lost`]), so it is answered `err lost-bytes` instead
//! of running with bytes missing (`set target 358` never becomes `set target 38`).

use core::cell::Cell;
use core::sync::atomic::{AtomicU32, Ordering};

use embassy_stm32::interrupt;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;

/// Size of the console's receive ring, bytes.
pub const RX_BUF: usize = 1024;

/// Bytes the interrupt let into the ring since boot (wrapping).
static ACCEPTED: AtomicU32 = AtomicU32::new(0);
/// Bytes the reader took out of the ring since boot (wrapping).
static TAKEN: AtomicU32 = AtomicU32::new(0);
/// Stream positions of losses not yet seen by the reader: the first and the last.
static LOST: Mutex<CriticalSectionRawMutex, Cell<Option<(u32, u32)>>> = Mutex::new(Cell::new(None));

fn record_loss(at: u32) {
    LOST.lock(|l| {
        l.set(Some(match l.get() {
            Some((first, _)) => (first, at),
            None => (at, at),
        }))
    });
}

/// The USART2 interrupt's first handler: detects a full ring and hardware overruns.
pub struct RxLossWatch;

impl interrupt::typelevel::Handler<interrupt::typelevel::USART2> for RxLossWatch {
    unsafe fn on_interrupt() {
        // Reading SR clears nothing: embassy's handler reads it again and then the data.
        let sr = embassy_stm32::pac::USART2.sr().read();
        if !sr.rxne() {
            return;
        }
        let accepted = ACCEPTED.load(Ordering::Relaxed);
        let waiting = accepted.wrapping_sub(TAKEN.load(Ordering::Relaxed));
        if waiting as usize >= RX_BUF {
            // embassy drops this byte: it is missing before the next accepted one.
            record_loss(accepted);
        } else {
            ACCEPTED.store(accepted.wrapping_add(1), Ordering::Relaxed);
            if sr.ore() {
                // This byte is kept; what came after it while it waited was lost.
                record_loss(accepted.wrapping_add(1));
            }
        }
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

    /// Record that a read took `n` bytes out of the ring, and fetch the losses recorded.
    pub fn took(&mut self, n: usize) {
        TAKEN.store(
            TAKEN.load(Ordering::Relaxed).wrapping_add(n as u32),
            Ordering::Relaxed,
        );
        if let Some((a, b)) = LOST.lock(|l| l.take()) {
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
