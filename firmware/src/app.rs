//! The one owner of a control period: the e-stop button's level, the newest measurement, then
//! at most one console line, each a step of the [`Supervisor`], in that order.
//!
//! The board's control loop, every host-sim command (`run`, `console`, `paper`) and the tests
//! drive a [`Controller`] and apply the [`Period`] it returns; none of them orders the steps or
//! parses a line itself. A `save` or `load` returns its [`StoreRequest`] in the period with the
//! heater and the springs off: the caller applies those outputs, carries the request out (the
//! board on its flash, the simulator in a file), and hands the outcome to
//! [`Controller::finish_store`], which gives the command's reply.

use crate::channels::SpringSense;
use crate::command::{self, ParseError};
use crate::console::ConsoleError;
use crate::measurement::{Measurement, SensingHint};
use crate::outputs::Outputs;
use crate::supervisor::report::Reply;
use crate::supervisor::store::{StoreOutcome, StoreRequest};
use crate::supervisor::{Decision, Notice, Supervisor};
use crate::units::Millis;

/// The board's control period, ms: the control loop steps at least this often (besides every
/// measurement and console line) — the spring timing's resolution and the sensor-loss check's.
/// The simulator's board steps at the same period.
pub const CONTROL_PERIOD_MS: u64 = 50;

/// A console line as the reader gave it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Line<'a> {
    /// A whole line of text.
    Text(&'a str),
    /// A line the reader refused (too long, binary, bytes lost).
    Refused(ConsoleError),
}

/// What one control period decided.
#[derive(Clone, Debug, PartialEq)]
pub struct Period {
    /// The outputs to apply now (with a `store`: heater and springs off, held through it).
    pub outputs: Outputs,
    /// What the sensing pipeline should assume and weigh for the next frames.
    pub sensing: SensingHint,
    /// The reply to the line, if a line came (none while a `store` waits for its outcome).
    pub reply: Option<Reply>,
    /// Notices to print as `# {notice}` lines after the reply: warnings (`# warning: …`) and
    /// announcements (`# autotune done: …`).
    pub notices: [Option<Notice>; 2],
    /// A telemetry line is due ([`Controller::write_telemetry`], after the notices).
    pub telemetry: bool,
    /// The loop is alive: the caller may feed its watchdog.
    pub alive: bool,
    /// A `save` or `load` to carry out before the reply.
    pub store: Option<StoreRequest>,
    /// `reset` asks for the spring channels to be probed before its reply: apply `outputs`
    /// (spring power on, every gate off), read the channels once settled and hand the reading
    /// to [`Controller::finish_probe`].
    pub probe: bool,
}

/// The supervisor with the order of a control period around it.
#[derive(Clone, Debug)]
pub struct Controller {
    sup: Supervisor,
}

impl Controller {
    /// Drive `sup`.
    pub fn new(sup: Supervisor) -> Controller {
        Controller { sup }
    }

    /// Return the supervisor (for status, telemetry, the springs' memory).
    pub fn supervisor(&self) -> &Supervisor {
        &self.sup
    }

    /// One control period at `now`: the button's level (`None`: no button, as in a simulator
    /// without one), the spring channels' readings (`None`: none new this period, or no
    /// sensing), the newest measurement (if a new one came), then the line (if one came). A
    /// line that does not parse gets its error reply and still costs one step, as any line.
    pub fn period(
        &mut self,
        now: Millis,
        button: Option<bool>,
        springs: Option<&SpringSense>,
        frame: Option<&Measurement>,
        line: Option<Line<'_>>,
    ) -> Period {
        if let Some(pressed) = button {
            self.sup.button(now, pressed);
        }
        if let Some(sense) = springs {
            self.sup.sense_springs(sense);
        }
        let mut d = self.sup.step(now, frame, None);
        let alive = d.alive;
        let mut telemetry = d.telemetry;
        let mut notices = [d.notice.take(), None];
        let mut reply = None;
        if let Some(line) = line {
            let mut l = match line {
                Line::Text(text) => match command::parse(text) {
                    Ok(c) => self.sup.step(now, None, Some(c)),
                    Err(e) => self.parse_error(now, e),
                },
                Line::Refused(e) => self.parse_error(now, ParseError::from(e)),
            };
            telemetry |= l.telemetry;
            notices[1] = l.notice.take();
            reply = l.reply.take();
            d = l;
        }
        Period {
            outputs: d.outputs,
            sensing: d.sensing,
            reply,
            notices,
            telemetry,
            alive,
            store: d.store,
            probe: d.probe,
        }
    }

    fn parse_error(&mut self, now: Millis, e: ParseError) -> Decision {
        Decision {
            reply: Some(Reply::parse_error(e)),
            ..self.sup.step(now, None, None)
        }
    }

    /// Finish the period's `store` with its `outcome` at `now` (when the flash operation
    /// ended); return the command's reply.
    pub fn finish_store(&mut self, now: Millis, outcome: StoreOutcome<'_>) -> Reply {
        self.sup.finish_store(now, outcome)
    }

    /// Finish the period's probe with the channels' reading `sense` taken at `now`; return
    /// `reset`'s reply and the outputs to apply from now on (the probe's spring power off
    /// again: every output as the latched fault, or `stopped`, wants).
    pub fn finish_probe(&mut self, now: Millis, sense: &SpringSense) -> (Reply, Outputs) {
        let reply = self.sup.finish_probe(now, sense);
        (reply, self.sup.outputs())
    }

    /// Write the telemetry line (with its `#` and CR LF).
    pub fn write_telemetry(
        &self,
        now: Millis,
        out: &mut impl core::fmt::Write,
    ) -> core::fmt::Result {
        self.sup.write_telemetry(now, out)
    }

    /// The supervisor, for what only a caller that owns the hardware may do (the flash
    /// store's [`crate::storage::FlashStore::carry_out`]).
    pub fn supervisor_mut(&mut self) -> &mut Supervisor {
        &mut self.sup
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::Settings;
    use crate::supervisor::SpringMemory;

    fn controller() -> Controller {
        Controller::new(Supervisor::with_memory(
            Millis(0),
            Settings::DEFAULT,
            SpringMemory::RESTED,
        ))
    }

    #[test]
    fn a_period_orders_button_frame_and_line_and_replies_once() {
        let mut c = controller();
        let p = c.period(
            Millis(10),
            Some(false),
            None,
            None,
            Some(Line::Text("version")),
        );
        assert!(p.reply.unwrap().as_str().starts_with("ok "));
        let p = c.period(Millis(20), Some(false), None, None, Some(Line::Text("fly")));
        assert!(p.reply.unwrap().as_str().starts_with("err unknown-command"));
        let p = c.period(
            Millis(30),
            None,
            None,
            None,
            Some(Line::Refused(ConsoleError::LineTooLong)),
        );
        assert!(p.reply.unwrap().as_str().starts_with("err line-too-long"));
        // The button pressed in the same period as a `mode` line: the e-stop wins.
        let p = c.period(
            Millis(40),
            Some(true),
            None,
            None,
            Some(Line::Text("mode standby")),
        );
        assert!(p.reply.unwrap().as_str().starts_with("err fault-latched"));
        assert_eq!(p.outputs, Outputs::OFF);
    }

    #[test]
    fn a_store_comes_with_the_heater_off_and_its_reply_after() {
        let mut c = controller();
        let p = c.period(Millis(10), None, None, None, Some(Line::Text("save")));
        assert!(p.reply.is_none());
        let Some(StoreRequest::Save(_)) = p.store else {
            panic!("{p:?}")
        };
        assert_eq!(p.outputs.heater.fraction(), 0.0);
        let r = c.finish_store(Millis(2000), StoreOutcome::Saved);
        assert!(r.as_str().starts_with("ok saved"), "{r:?}");
    }
}
