//! The spring channels in the supervisor: each period's readings judged against the outputs
//! they were taken under, a fault latched (which cuts the spring power in the same decision), a
//! sagging supply reported, and `reset`'s probe of every channel.
//!
//! `reset` may clear a fault only when no channel conducts with its gate off; the spring power
//! is off while a fault is latched, so nothing could be seen. With a board that senses its
//! springs, `reset` (once every other cause is gone) asks for a probe ([`Decision::probe`]):
//! the caller turns the spring power on with every gate off, reads the channels once they have
//! settled and hands the reading to [`Supervisor::finish_probe`], which clears the fault or
//! refuses with the channel that conducts. A stuck MOSFET is powered for that one reading
//! only (a few ms).

use super::events::{EventKind, Notice, Warning};
use super::report::Reply;
use super::safety::Fault;
use super::Supervisor;
use crate::channels::{Channels, SpringSense};
use crate::outputs::{Outputs, SPRING_NAMES};
use crate::units::Millis;

/// A sagging supply is reported at most this often, ms.
pub const SAG_WARN_EVERY_MS: u64 = 60_000;

impl Supervisor {
    /// The spring channels' readings of this control period (taken while the last decision's
    /// outputs were applied): the next [`Supervisor::step`] judges them. The board and the
    /// simulator call it once a period, before the period's steps.
    pub fn sense_springs(&mut self, sense: &SpringSense) {
        self.sense = Some(*sense);
    }

    /// Return the spring channels as measured.
    pub fn channels(&self) -> &Channels {
        &self.channels
    }

    /// Put the boot calibration of the channels in use (the board's, before the first step).
    pub fn set_channels(&mut self, channels: Channels) {
        self.channels = channels;
    }

    /// Judge `sense`, read while `ran` was applied: latch a channel's fault, report a sag.
    pub(super) fn check_channels(&mut self, now: Millis, sense: &SpringSense, ran: Outputs) {
        let (fault, sag) = self
            .channels
            .update(sense, ran.springs, ran.spring_power, &self.settings);
        if let Some(f) = fault {
            self.latch(now, Fault::Channel(f));
        }
        let due = self
            .sag_warned
            .is_none_or(|t| now.0 >= t.0 + SAG_WARN_EVERY_MS);
        if let Some(g) = sag.filter(|_| due && self.fault.is_none()) {
            self.sag_warned = Some(now);
            let w = Warning::SupplySag {
                spring: g.spring,
                supply_v: g.supply_v,
                current_a: g.current_a,
            };
            self.events.push(now, EventKind::Warning(w));
            self.notice = Some(Notice::Warning(w));
        }
    }

    /// Finish `reset`'s probe with the channels' reading `sense` (spring power on, every gate
    /// off) at `now`: clear the fault when no channel conducts, else refuse naming it. The
    /// spring power goes off again with the next decision.
    pub fn finish_probe(&mut self, now: Millis, sense: &SpringSense) -> Reply {
        if !core::mem::take(&mut self.probe_pending) {
            return Reply::err("internal", "no probe was asked for");
        }
        self.outputs.spring_power = false;
        let (conducting, amps) = self.channels.probe(sense, &self.settings);
        match (0..crate::outputs::SPRINGS).find(|&i| conducting.contains(i)) {
            Some(i) => Reply::conducting(SPRING_NAMES[i], amps),
            None => self.clear_fault(now),
        }
    }

    /// Whether `reset` must probe the channels before it clears (a board that senses them).
    pub(super) fn needs_probe(&self) -> bool {
        self.channels.present()
    }
}
