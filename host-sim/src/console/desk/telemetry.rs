//! Telemetry and `status` lines as named fields, and the recording's CSV.
//!
//! Both are `name=value` words (`status` after `ok`, telemetry after `#`); a value may be
//! quoted (`reason="…"`). The telemetry fields and their order are the library's
//! [`TELEMETRY_FIELDS`]; the CSV is `time_s` (host seconds since the recording started, steady
//! across board resets), those fields in that order, and `gap` (`-`, or why rows may be missing
//! just before this one: `reset`, `reconnect`, `silence`).
//!
//! [`status_fields`] are the `status` reply's field names as the library writes them, so a
//! script's `wait`/`expect` can be checked before anything is sent.

use thermorph::supervisor::report::TELEMETRY_FIELDS;

/// `name=value` pairs of a line, in order.
pub type Fields = Vec<(String, String)>;

/// Split `name=value` words (values may be double-quoted and hold spaces); words without `=`
/// are skipped.
pub fn fields(text: &str) -> Fields {
    let mut out = Vec::new();
    let mut rest = text.trim();
    while !rest.is_empty() {
        let word_end = rest.find(char::is_whitespace).unwrap_or(rest.len());
        let Some(eq) = rest[..word_end].find('=') else {
            rest = rest[word_end..].trim_start();
            continue;
        };
        let name = &rest[..eq];
        let after = &rest[eq + 1..];
        let (value, next) = if let Some(q) = after.strip_prefix('"') {
            match q.find('"') {
                Some(end) => (&q[..end], &q[end + 1..]),
                None => (q, ""),
            }
        } else {
            let end = after.find(char::is_whitespace).unwrap_or(after.len());
            (&after[..end], &after[end..])
        };
        out.push((name.to_string(), value.to_string()));
        rest = next.trim_start();
    }
    out
}

/// Return the value of `name` in `f`.
pub fn get<'a>(f: &'a Fields, name: &str) -> Option<&'a str> {
    f.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_str())
}

/// The field names of a `status` reply, in the order the library writes them, learned from the
/// library itself: a fresh supervisor is given a frame (so the frame's fields are there), then
/// one hot enough to latch a fault (so the fault's `reason` is there too), and asked for
/// `status`.
pub fn status_fields() -> Vec<String> {
    use thermorph::measurement::{Measurement, Quality};
    use thermorph::settings::Settings;
    use thermorph::supervisor::Supervisor;
    use thermorph::units::{Kelvin, Millis};
    let frame = |ms: u64, k: f32| Measurement {
        at: Millis(ms),
        seq: ms as u32,
        regions: [Kelvin::new(k); thermorph::mtts::REGIONS],
        hottest: Kelvin::new(k),
        filled_pixels: 0,
        quality: Quality::Resolved,
        bound: Kelvin::lit(0.5),
        tilt: None,
        exposure: None,
    };
    let mut s = Supervisor::new(Millis(0), Settings::DEFAULT);
    s.step(Millis(100), Some(&frame(100, 300.0)), None);
    s.step(Millis(200), Some(&frame(200, 900.0)), None);
    let status = thermorph::command::parse("status").ok();
    let reply = s.step(Millis(210), None, status).reply;
    let text = reply.as_ref().map_or("", |r| r.as_str());
    fields(text.strip_prefix("ok").unwrap_or(""))
        .into_iter()
        .map(|(n, _)| n)
        .collect()
}

/// A parsed telemetry line: the library's fields, in [`TELEMETRY_FIELDS`] order (`None` where
/// the line lacked one).
#[derive(Clone, Debug, PartialEq)]
pub struct Telemetry {
    /// Values in [`TELEMETRY_FIELDS`] order.
    pub values: [Option<String>; TELEMETRY_FIELDS.len()],
}

impl Telemetry {
    /// Parse a `# t_s=… mode=… …` line; `None` if it is not one (no `#`, or no `t_s`).
    pub fn parse(line: &str) -> Option<Telemetry> {
        let body = line.trim().strip_prefix('#')?;
        let f = fields(body);
        get(&f, TELEMETRY_FIELDS[0])?;
        Some(Telemetry {
            values: TELEMETRY_FIELDS.map(|n| get(&f, n).map(str::to_string)),
        })
    }

    /// Return a field by name.
    pub fn get(&self, name: &str) -> Option<&str> {
        let i = TELEMETRY_FIELDS.iter().position(|n| *n == name)?;
        self.values[i].as_deref()
    }

    /// Return the board's clock, s.
    pub fn t_s(&self) -> Option<f64> {
        self.get("t_s")?.parse().ok()
    }

    /// A one-line summary for a person (the console's status line).
    pub fn summary(&self) -> String {
        let g = |n| self.get(n).unwrap_or("?");
        format!(
            "t={} s {} T1={} T2={} Tc={} target={} heater={}% fan={}% springs={} fault={}",
            g("t_s"),
            g("mode"),
            g("t1_k"),
            g("t2_k"),
            g("tc_k"),
            g("target_k"),
            g("heater_pct"),
            g("fan_pct"),
            g("springs"),
            g("fault")
        )
    }
}

/// The recording's CSV header line.
pub fn csv_header() -> String {
    format!("time_s,{},gap", TELEMETRY_FIELDS.join(","))
}

/// One CSV row: host time, the fields (empty where missing; commas cannot occur in the
/// board's values but are replaced to keep the columns), the gap mark.
pub fn csv_row(host_s: f64, t: &Telemetry, gap: Option<&str>) -> String {
    let mut s = format!("{host_s:.3}");
    for v in &t.values {
        s.push(',');
        s.push_str(&v.as_deref().unwrap_or("").replace(',', ";"));
    }
    s.push(',');
    s.push_str(gap.unwrap_or("-"));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_fields_with_quotes() {
        let f = fields(
            "mode=fault phase=- tc_k=300.10 fault=heater-open reason=\"no rise in 30 s\" x=1",
        );
        assert_eq!(get(&f, "mode"), Some("fault"));
        assert_eq!(get(&f, "reason"), Some("no rise in 30 s"));
        assert_eq!(get(&f, "x"), Some("1"));
        assert_eq!(get(&f, "nope"), None);
        assert_eq!(fields("ok junk a=1"), vec![("a".into(), "1".into())]);
    }

    #[test]
    fn a_library_telemetry_line_round_trips_to_csv() {
        use thermorph::settings::Settings;
        use thermorph::supervisor::Supervisor;
        use thermorph::units::Millis;
        let s = Supervisor::new(Millis(0), Settings::DEFAULT);
        let mut line = String::new();
        s.write_telemetry(Millis(12_345), &mut line).unwrap();
        let t = Telemetry::parse(&line).expect(&line);
        assert_eq!(t.t_s(), Some(12.345));
        assert_eq!(t.get("mode"), Some("standby"));
        assert_eq!(t.get("fault"), Some("none"));
        assert!(t.values.iter().all(Option::is_some), "{t:?}");
        let header = csv_header();
        let row = csv_row(1.5, &t, Some("reset"));
        assert_eq!(header.split(',').count(), row.split(',').count());
        assert!(header.starts_with("time_s,t_s,mode,"));
        assert!(row.starts_with("1.500,12.345,standby,") && row.ends_with(",reset"));
    }

    #[test]
    fn status_fields_come_from_the_library() {
        let f = status_fields();
        for n in [
            "mode", "phase", "tc_k", "t1_k", "filled", "springs", "fault", "reason",
        ] {
            assert!(f.iter().any(|x| x == n), "{n} not in {f:?}");
        }
        // Every telemetry field but the board's clock is a `status` field too.
        for n in TELEMETRY_FIELDS.iter().filter(|n| **n != "t_s") {
            assert!(f.iter().any(|x| x == n), "{n} not in {f:?}");
        }
    }

    #[test]
    fn non_telemetry_lines_are_refused() {
        assert!(Telemetry::parse("ok t_s=1").is_none());
        assert!(Telemetry::parse("# event mode").is_none());
        let t = Telemetry::parse("# t_s=2 mode=form extra=9").unwrap();
        assert_eq!(t.get("mode"), Some("form"));
        assert_eq!(t.get("t1_k"), None);
        assert_eq!(
            csv_row(0.0, &t, None),
            format!("0.000,2,form{},-", ",".repeat(TELEMETRY_FIELDS.len() - 2))
        );
    }
}
