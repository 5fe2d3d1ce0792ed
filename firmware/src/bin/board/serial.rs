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

#[path = "loss.rs"]
mod loss;
pub use loss::LossTracker;

/// Size of the console's receive ring, bytes.
pub const RX_BUF: usize = 1024;

/// Bytes the interrupt let into the ring since boot (wrapping).
static ACCEPTED: AtomicU32 = AtomicU32::new(0);
/// Bytes the reader took out of the ring since boot (wrapping).
static TAKEN: AtomicU32 = AtomicU32::new(0);
/// Stream positions of losses not yet seen by the reader: the first and the last.
static LOST: Mutex<CriticalSectionRawMutex, Cell<Option<(u32, u32)>>> = Mutex::new(Cell::new(None));

fn record_loss(at: u32) {
    LOST.lock(|l| l.set(loss::merge(l.get(), at)));
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
        let (accepted, lost) = loss::on_receive(
            ACCEPTED.load(Ordering::Relaxed),
            TAKEN.load(Ordering::Relaxed),
            sr.ore(),
            RX_BUF,
        );
        ACCEPTED.store(accepted, Ordering::Relaxed);
        if let Some(at) = lost {
            record_loss(at);
        }
    }
}

/// Record that a read took `n` bytes out of the ring, and return the losses recorded since
/// the last call (for [`LossTracker::add`]).
pub fn took(n: usize) -> Option<(u32, u32)> {
    TAKEN.store(
        TAKEN.load(Ordering::Relaxed).wrapping_add(n as u32),
        Ordering::Relaxed,
    );
    LOST.lock(|l| l.take())
}
