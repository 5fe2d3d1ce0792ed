//! `save`, `load` and `defaults`: the supervisor decides, the board (or host-sim) stores.
//!
//! The supervisor stays pure: it never touches flash or a file. A `save` or `load` command
//! makes its step return [`Decision::store`](super::Decision::store) = a [`StoreRequest`]
//! instead of a reply; the caller carries it out (the board on its flash, host-sim in a file)
//! and hands the outcome to [`Supervisor::finish_store`], which returns the command's one reply.
//! `defaults` needs no storage and replies at once. At power-up the caller reads the stored
//! record once and starts the supervisor with [`settings_at_boot`]: a bad or old record falls
//! back to the defaults with a `# warning` line.
//!
//! `save` and `load` are refused while a mode drives the block (stepping, forming, recovery,
//! autotune): on the F446 a flash erase stalls the CPU for up to a second or two, longer than the
//! sensor-loss window, so they run only in standby, stopped or with a fault latched. The step
//! that asks for one decides the heater and the springs off (the fan as the mode wants); the
//! caller applies that decision before the flash operation and holds it through it, and
//! [`Supervisor::finish_store`] takes the time the operation ended, from which the sensor-loss
//! window counts again (the sensor stalls with the core: no nuisance sensor loss).

use core::fmt::Write;

use super::Supervisor;
use super::report::Reply;
use crate::settings::{PARAMS, RECORD_LEN, RECORD_VERSION, Record, Settings};
use crate::units::Millis;

/// What the caller must do for a `save` or `load`.
// No allocator to box the record in; a request is made and moved once per `save`.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StoreRequest {
    /// Write this record, replacing the stored one.
    Save(Record),
    /// Read the stored record.
    Load,
}

/// What came of a [`StoreRequest`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoreOutcome<'a> {
    /// The record was written (and read back equal, where the storage can check).
    Saved,
    /// The stored bytes (`None`: nothing is stored).
    Loaded(Option<&'a [u8]>),
    /// The storage failed; why.
    Failed(&'static str),
}

/// The settings to start with: the stored record's (`stored`: its bytes, `None` when nothing is
/// stored) or, for a bad or old record, the defaults after writing a `# warning: …` line (with
/// CR LF) to `console`.
pub fn settings_at_boot(stored: Option<&[u8]>, console: &mut impl Write) -> Settings {
    match stored.map(Settings::decode) {
        None => Settings::DEFAULT,
        Some(Ok(s)) => s,
        Some(Err(e)) => {
            let _ = write!(
                console,
                "# warning: stored settings not used ({e}); defaults in use\r\n"
            );
            Settings::DEFAULT
        }
    }
}

impl Supervisor {
    /// `save`: ask for the record to be written (refused while a mode drives the block).
    pub(super) fn save(&mut self) -> Reply {
        self.store_request(StoreRequest::Save(self.settings.encode()))
    }

    /// `load`: ask for the stored record (where `save` is allowed).
    pub(super) fn load(&mut self) -> Reply {
        self.store_request(StoreRequest::Load)
    }

    fn store_request(&mut self, req: StoreRequest) -> Reply {
        if self.mode.id().drives_block() {
            return Reply::err(
                "bad-state",
                "save and load only in standby, stopped or fault (the flash stalls the board)",
            );
        }
        self.store = Some(req);
        // Replaced by `finish_store`'s reply.
        Reply::ok("storing")
    }

    /// `defaults`: every parameter back to its default, in RAM (refused where that would
    /// relax a limit while a fault is latched).
    pub(super) fn defaults(&mut self) -> Reply {
        if let Err(name) = self.take_settings(Settings::DEFAULT) {
            return Reply::relaxed(name);
        }
        Reply::ok("defaults in use (`save` keeps them)")
    }

    /// Put `s` in use, unless a fault is latched and `s` relaxes one of the limits in use (SPEC
    /// section 5: while a fault is latched no limit can be relaxed); then nothing changes and
    /// the error is the limit's name.
    fn take_settings(&mut self, s: Settings) -> Result<(), &'static str> {
        if self.fault.is_some()
            && let Some(name) = self.settings.relaxed_by(&s)
        {
            return Err(name);
        }
        self.configure(s);
        Ok(())
    }

    /// Finish a `save` or `load` the last step asked for ([`Decision::store`](super::Decision))
    /// at `now`, when the flash operation ended; return the command's reply. A loaded record
    /// that is bad or old puts the defaults in use, as at power-up; a failed read changes
    /// nothing. The sensor-loss window restarts at `now`.
    pub fn finish_store(&mut self, now: Millis, outcome: StoreOutcome<'_>) -> Reply {
        self.sensor_grace = self.sensor_grace.max(now);
        match outcome {
            StoreOutcome::Saved => {
                let mut r = Reply::ok("");
                let _ = write!(
                    r,
                    "saved {} parameters (record v{RECORD_VERSION}, {RECORD_LEN} bytes)",
                    PARAMS.len()
                );
                r
            }
            StoreOutcome::Loaded(None) => match self.take_settings(Settings::DEFAULT) {
                Ok(()) => Reply::ok("nothing stored, defaults in use"),
                Err(name) => Reply::relaxed(name),
            },
            StoreOutcome::Loaded(Some(bytes)) => match Settings::decode(bytes) {
                Ok(s) => match self.take_settings(s) {
                    Ok(()) => {
                        let mut r = Reply::ok("");
                        let _ = write!(r, "loaded {} parameters", PARAMS.len());
                        r
                    }
                    Err(name) => Reply::relaxed(name),
                },
                Err(e) => {
                    let used = self.take_settings(Settings::DEFAULT).is_ok();
                    let mut r = Reply::err("bad-record", "");
                    let _ = write!(
                        r,
                        "{e}; {}",
                        if used {
                            "defaults in use"
                        } else {
                            "settings unchanged (the defaults would relax a limit while a fault is latched)"
                        }
                    );
                    r
                }
            },
            StoreOutcome::Failed(why) => Reply::err("store-failed", why),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::Decision;
    use super::*;
    use crate::command::{Command, parse};
    use crate::supervisor::ModeId;
    use crate::units::Millis;
    use std::format;
    use std::string::String;

    fn run(s: &mut Supervisor, line: &str) -> Decision {
        s.step(Millis(10), None, Some(parse(line).unwrap()))
    }

    #[test]
    fn save_then_load_restores_every_parameter() {
        let mut s = Supervisor::new(Millis(0), Settings::DEFAULT);
        assert!(run(&mut s, "set hot_k 360").reply.unwrap().is_ok());
        assert!(run(&mut s, "set kp 0.2").reply.unwrap().is_ok());
        let d = run(&mut s, "save");
        assert_eq!(d.reply, None, "the reply comes from finish_store");
        let Some(StoreRequest::Save(record)) = d.store else {
            panic!("no save request: {d:?}");
        };
        let r = s.finish_store(Millis(10), StoreOutcome::Saved);
        let n = PARAMS.len();
        assert_eq!(
            r.as_str(),
            format!("ok saved {n} parameters (record v1, {} bytes)", 16 + 4 * n)
        );

        let d = run(&mut s, "defaults");
        assert!(d.store.is_none());
        assert_eq!(s.settings().hot_k, Settings::DEFAULT.hot_k);
        assert!(d.reply.unwrap().is_ok());

        let d = run(&mut s, "load");
        assert_eq!((d.reply, d.store), (None, Some(StoreRequest::Load)));
        let r = s.finish_store(Millis(10), StoreOutcome::Loaded(Some(&record)));
        assert_eq!(r.as_str(), format!("ok loaded {n} parameters"));
        assert_eq!(s.settings().hot_k, 360.0);
        assert_eq!(s.settings().gains.kp_per_k, 0.2);
    }

    #[test]
    fn bad_or_missing_records_fall_back_to_defaults() {
        let mut s = Supervisor::new(Millis(0), Settings::DEFAULT);
        run(&mut s, "set hot_k 360");
        let mut bad = s.settings().encode();
        bad[20] ^= 4;
        run(&mut s, "load");
        let r = s.finish_store(Millis(10), StoreOutcome::Loaded(Some(&bad)));
        assert_eq!(r.as_str(), "err bad-record: CRC mismatch; defaults in use");
        assert_eq!(*s.settings(), Settings::DEFAULT);

        run(&mut s, "set hot_k 360");
        let r = s.finish_store(Millis(10), StoreOutcome::Loaded(None));
        assert_eq!(r.as_str(), "ok nothing stored, defaults in use");
        assert_eq!(*s.settings(), Settings::DEFAULT);

        run(&mut s, "set hot_k 360");
        let r = s.finish_store(Millis(10), StoreOutcome::Failed("flash read error"));
        assert_eq!(r.as_str(), "err store-failed: flash read error");
        assert_eq!(s.settings().hot_k, 360.0, "a failed read changes nothing");
    }

    #[test]
    fn save_is_refused_while_a_mode_drives_the_block() {
        let mut s = Supervisor::new(Millis(0), Settings::DEFAULT);
        s.step(
            Millis(5),
            None,
            Some(Command::Mode(ModeId::StepLarge, None)),
        );
        let d = run(&mut s, "save");
        assert!(d.store.is_none());
        assert!(d.reply.unwrap().as_str().starts_with("err bad-state:"));
        run(&mut s, "stop");
        assert!(run(&mut s, "save").store.is_some());
    }

    #[test]
    fn boot_uses_a_good_record_and_warns_on_a_bad_one() {
        let mut good = Settings::DEFAULT;
        good.hot_k = 361.0;
        let rec = good.encode();
        let mut out = String::new();
        assert_eq!(settings_at_boot(Some(&rec), &mut out), good);
        assert_eq!(settings_at_boot(None, &mut out), Settings::DEFAULT);
        assert!(out.is_empty());
        let mut old = rec;
        old[4] = 0;
        assert_eq!(settings_at_boot(Some(&old), &mut out), Settings::DEFAULT);
        assert_eq!(
            out,
            "# warning: stored settings not used (record version 0, expected 1); defaults in use\r\n"
        );
    }
}
