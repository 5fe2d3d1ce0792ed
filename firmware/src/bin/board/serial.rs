//! Console input that never loses or garbles a byte silently.
//!
//! embassy's buffered UART (embassy-stm32 0.6, `usart/buffered.rs`) reads the data register on
//! every receive interrupt and only *logs* what went wrong: a byte that meets a full receive
//! ring is dropped, a hardware overrun (ORE) has lost a byte, and a byte with a framing error
//! (FE, also a break), noise (NF) or a parity error (PE) is put in the ring as if it were good;
//! its `read` never returns an error. [`RxLossWatch`] runs in the USART2 interrupt just before
//! embassy's handler, reads the status register (SR; reading it clears nothing, embassy's read
//! of the data register does) and records, in a [`loss::Watch`], where in the byte stream each
//! of these happened; the console reader counts the bytes it takes out ([`took`]) and its
//! [`LossTracker`] marks the line those positions fall in as lost
//! ([`thermorph::console::LineReader::mark_lost`]), so it is answered `err lost-bytes` instead
//! of running with bytes missing or wrong (`set target 358` never becomes `set target 38`).
//!
//! Caught, each marking the line the position falls in:
//! - a byte meeting a full ring (the next byte's line);
//! - an overrun, with a byte waiting in the data register (the line of the byte after it) or
//!   without one (the previous byte was taken just before: the next byte's line);
//! - FE, NF or PE on the byte in the data register (that byte's line: a line end received
//!   damaged refuses that line; a line end garbled into another byte merges two lines into one
//!   refused line). Parity is off (8N1), so PE does not occur.
//!
//! Not caught:
//! - a byte changed on the wire that still has a good stop bit and no noisy sample (8N1 has
//!   no parity to check);
//! - a flag raised in the few cycles between this watch's read of SR and embassy's: a byte
//!   completing there reaches the ring uncounted (and unchecked for FE/NF), and an overrun
//!   there (which needs the interrupt already a whole byte late) goes unrecorded. An
//!   uncounted byte is put right when the reader next takes it ([`loss::Watch::took`]); a loss
//!   recorded before then is marked one byte early, which can be on the previous line.

use core::cell::Cell;

use embassy_stm32::interrupt;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;

#[path = "loss.rs"]
mod loss;
pub use loss::LossTracker;

/// Size of the console's receive ring, bytes.
pub const RX_BUF: usize = 1024;

/// The interrupt's and the reader's byte counts and the losses not yet handed to the reader.
static WATCH: Mutex<CriticalSectionRawMutex, Cell<loss::Watch>> =
    Mutex::new(Cell::new(loss::Watch::new()));

/// The USART2 interrupt's first handler: detects a full ring, overruns and damaged bytes.
pub struct RxLossWatch;

impl interrupt::typelevel::Handler<interrupt::typelevel::USART2> for RxLossWatch {
    unsafe fn on_interrupt() {
        let sr = embassy_stm32::pac::USART2.sr().read();
        let status = loss::RxStatus {
            received: sr.rxne(),
            overrun: sr.ore(),
            damaged: sr.fe() || sr.ne() || sr.pe(),
        };
        if status == loss::RxStatus::default() {
            // A transmit or idle-line interrupt.
            return;
        }
        WATCH.lock(|w| {
            let mut watch = w.get();
            watch.on_interrupt(status, RX_BUF);
            w.set(watch);
        });
    }
}

/// Record that a read took `n` bytes out of the ring, and return the losses recorded since
/// the last call (for [`LossTracker::add`]).
pub fn took(n: usize) -> Option<(u32, u32)> {
    WATCH.lock(|w| {
        let mut watch = w.get();
        let lost = watch.took(n);
        w.set(watch);
        lost
    })
}
