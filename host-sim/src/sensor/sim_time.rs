//! Simulated time: a shared microsecond clock and a delay that advances it instead of waiting.

use std::cell::Cell;
use std::rc::Rc;

use embedded_hal_async::delay::DelayNs;

/// A shared simulated clock in microseconds; clones see the same time.
#[derive(Clone, Debug, Default)]
pub struct SimClock(Rc<Cell<u64>>);

impl SimClock {
    /// Make a clock at t = 0.
    pub fn new() -> Self {
        Self::default()
    }

    /// Return the time, µs.
    pub fn now_us(&self) -> u64 {
        self.0.get()
    }

    /// Move the clock forward by `us`.
    pub fn advance_us(&self, us: u64) {
        self.0.set(self.0.get() + us);
    }
}

/// A delay that completes at once and advances the simulated clock by the requested time.
#[derive(Clone, Debug)]
pub struct SimDelay {
    clock: SimClock,
    remainder_ns: u32,
}

impl SimDelay {
    /// Make a delay on `clock`.
    pub fn new(clock: SimClock) -> Self {
        SimDelay {
            clock,
            remainder_ns: 0,
        }
    }
}

impl DelayNs for SimDelay {
    async fn delay_ns(&mut self, ns: u32) {
        let total = self.remainder_ns as u64 + ns as u64;
        self.clock.advance_us(total / 1000);
        self.remainder_ns = (total % 1000) as u32;
    }
}
