//! The board's defmt log in an ELF run (`--features pil`): the bytes its logger writes to RTT
//! up channel 0 (read off the chip by [`crate::f446::rtt`]) decoded with the ELF's own `.defmt`
//! table (the `defmt-decoder` crate, defmt 1.x's wire format) into [`LogRecord`]s — the frame's
//! timestamp (the board's is embassy's uptime), level and message, as a probe shows them.
//!
//! Bytes come in pieces as the harness reads them; a frame split between two reads is kept
//! until its end arrives. Nothing the board writes can stop the run: a frame the table does not
//! describe, bytes of a frame cut off (by a chip reset, or the ring written over) and an ELF
//! whose table cannot be read each become one note in the log, and decoding goes on at the next
//! frame (rzCOBS frames end at a zero byte; the raw encoding cannot find a next frame, so its
//! bytes after an undecodable one are dropped with a note).

use defmt_decoder::{DecodeError, Encoding, Frame, Table};

use crate::runs::run::LogRecord;

/// The board's defmt log as it is decoded.
pub struct DefmtLog {
    /// The ELF's table, or why there is none.
    table: Result<Table, String>,
    /// Bytes not yet decoded: the start of a frame whose end has not arrived.
    pending: Vec<u8>,
    /// Bytes that could not be decoded for want of a table, not yet noted.
    unread: usize,
    /// The lines so far.
    records: Vec<LogRecord>,
}

/// A frame's level as a probe prints it.
fn level_name(frame: &Frame<'_>) -> Option<&'static str> {
    frame.level().map(|l| match l.as_str() {
        "trace" => "TRACE",
        "debug" => "DEBUG",
        "info" => "INFO",
        "warn" => "WARN",
        _ => "ERROR",
    })
}

impl DefmtLog {
    /// A log decoded with the `.defmt` table of the ELF `elf` (its bytes). An ELF without one,
    /// or one whose table cannot be read, gives a log of notes (the bytes its RTT carries are
    /// counted, not decoded).
    pub fn new(elf: &[u8]) -> DefmtLog {
        let table = match Table::parse(elf) {
            Ok(Some(t)) => Ok(t),
            Ok(None) => Err("the ELF has no .defmt table".to_string()),
            Err(e) => Err(format!("the ELF's .defmt table cannot be read: {e:#}")),
        };
        DefmtLog {
            table,
            pending: Vec::new(),
            unread: 0,
            records: Vec::new(),
        }
    }

    /// Decode `bytes` (read off the chip at `at_s`, s of the run) after those given before:
    /// the records of the frames they complete.
    pub fn push(&mut self, bytes: &[u8], at_s: f64) -> &[LogRecord] {
        let start = self.records.len();
        let table = match &self.table {
            Ok(t) => t,
            Err(_) => {
                self.unread += bytes.len();
                return &[];
            }
        };
        self.pending.extend_from_slice(bytes);
        let note = |text: String| LogRecord {
            at_s,
            timestamp: None,
            level: None,
            text,
        };
        let record = |frame: &Frame<'_>| LogRecord {
            at_s,
            timestamp: frame.display_timestamp().map(|t| t.to_string()),
            level: level_name(frame),
            text: frame.display_message().to_string(),
        };
        match table.encoding() {
            Encoding::Rzcobs => {
                // Whole frames: up to the last separator.
                let Some(end) = self.pending.iter().rposition(|&b| b == 0) else {
                    return &[];
                };
                let whole: Vec<u8> = self.pending.drain(..=end).collect();
                for frame in whole.split(|&b| b == 0).filter(|f| !f.is_empty()) {
                    let mut decoder = table.new_stream_decoder();
                    decoder.received(frame);
                    decoder.received(&[0]);
                    match decoder.decode() {
                        Ok(f) => self.records.push(record(&f)),
                        Err(e) => self.records.push(note(format!(
                            "undecodable defmt frame ({} bytes): {}",
                            frame.len(),
                            why(e)
                        ))),
                    }
                }
            }
            _ => loop {
                if self.pending.is_empty() {
                    break;
                }
                match table.decode(&self.pending) {
                    Ok((f, used)) => {
                        self.records.push(record(&f));
                        self.pending.drain(..used);
                    }
                    Err(DecodeError::UnexpectedEof) => break,
                    Err(DecodeError::Malformed) => {
                        self.records.push(note(format!(
                            "undecodable defmt frame: {}; {} bytes dropped (the raw encoding \
                             has no frame boundary to resume at)",
                            why(DecodeError::Malformed),
                            self.pending.len()
                        )));
                        self.pending.clear();
                    }
                }
            },
        }
        &self.records[start..]
    }

    /// Add a note of the harness's (`text`, at `at_s`, s of the run): what kept it from reading
    /// the log.
    pub fn note(&mut self, at_s: f64, text: String) {
        self.records.push(LogRecord {
            at_s,
            timestamp: None,
            level: None,
            text,
        });
    }

    /// The log at the end of the run (`at_s`, s): a note for bytes of a frame never finished
    /// and for bytes not decoded for want of a table.
    pub fn finish(mut self, at_s: f64) -> Vec<LogRecord> {
        let mut note = |text: String| {
            self.records.push(LogRecord {
                at_s,
                timestamp: None,
                level: None,
                text,
            })
        };
        if !self.pending.is_empty() {
            note(format!(
                "{} bytes of a defmt frame not finished by the end of the run",
                self.pending.len()
            ));
        }
        if let Err(why) = &self.table
            && self.unread > 0
        {
            note(format!("{} bytes of RTT not decoded: {why}", self.unread));
        }
        self.records
    }
}

/// Why a frame did not decode, in the log's words.
fn why(e: DecodeError) -> &'static str {
    match e {
        DecodeError::Malformed => "not a frame of this ELF's defmt table",
        DecodeError::UnexpectedEof => "cut short",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use object::write::{Object as WObject, Symbol, SymbolSection};
    use object::{Architecture, BinaryFormat, SectionKind, SymbolFlags, SymbolKind, SymbolScope};

    /// An ELF with a `.defmt` table as defmt 1.x links it: the version and encoding symbols,
    /// a `{=u64:us}` timestamp (embassy's uptime) at index 1, and these log statements from
    /// index 2 (`(tag, format)`).
    fn elf(encoding: &str, entries: &[(&str, &str)]) -> Vec<u8> {
        let mut o = WObject::new(
            BinaryFormat::Elf,
            Architecture::Arm,
            object::Endianness::Little,
        );
        let defmt = o.add_section(Vec::new(), b".defmt".to_vec(), SectionKind::ReadOnlyData);
        o.append_section_data(defmt, &vec![0u8; 2 + entries.len()], 1);
        let mut add = |name: String, value: u64, section: SymbolSection| {
            o.add_symbol(Symbol {
                name: name.into_bytes(),
                value,
                size: 0,
                kind: SymbolKind::Data,
                scope: SymbolScope::Linkage,
                weak: false,
                section,
                flags: SymbolFlags::None,
            });
        };
        add("_defmt_version_ = 4".into(), 0, SymbolSection::Absolute);
        add(
            format!("_defmt_encoding_ = {encoding}"),
            0,
            SymbolSection::Absolute,
        );
        let json = |tag: &str, data: &str, n: usize| {
            format!(
                r#"{{"package":"test","tag":"{tag}","data":"{data}","disambiguator":"{n}","crate_name":"test"}}"#
            )
        };
        add(
            json("defmt_timestamp", "{=u64:us}", 1),
            1,
            SymbolSection::Section(defmt),
        );
        for (i, (tag, data)) in entries.iter().enumerate() {
            add(
                json(tag, data, i + 2),
                (i + 2) as u64,
                SymbolSection::Section(defmt),
            );
        }
        o.write().unwrap()
    }

    const ENTRIES: [(&str, &str); 3] = [
        ("defmt_info", "thermorph {=str} up"),
        (
            "defmt_warn",
            "spring channel {=u8}: amplifier offset {=i16} counts",
        ),
        ("defmt_println", "plain"),
    ];

    /// A frame as defmt writes it: the statement's index, the timestamp, the arguments.
    fn frame(index: u16, uptime_us: u64, args: &[u8]) -> Vec<u8> {
        let mut f = index.to_le_bytes().to_vec();
        f.extend_from_slice(&uptime_us.to_le_bytes());
        f.extend_from_slice(args);
        f
    }

    /// defmt's rzCOBS encoder (defmt 1.x `encoding/rzcobs.rs`): a frame and its separator.
    fn rzcobs(data: &[u8]) -> Vec<u8> {
        let (mut out, mut run, mut zeros) = (Vec::new(), 0u8, 0u8);
        for &byte in data {
            if run < 7 {
                if byte == 0 {
                    zeros |= 1 << run;
                } else {
                    out.push(byte);
                }
                run += 1;
                if run == 7 && zeros != 0 {
                    out.push(zeros);
                    (run, zeros) = (0, 0);
                }
            } else if byte == 0 {
                out.push((run - 7) | 0x80);
                (run, zeros) = (0, 0);
            } else {
                out.push(byte);
                run += 1;
                if run == 134 {
                    out.push(0xFF);
                    (run, zeros) = (0, 0);
                }
            }
        }
        match run {
            0 => {}
            1..=6 => out.push((zeros | (0xFF << run)) & 0x7F),
            _ => out.push((run - 7) | 0x80),
        }
        out.push(0);
        out
    }

    fn up(uptime_us: u64) -> Vec<u8> {
        let mut args = 5u32.to_le_bytes().to_vec();
        args.extend_from_slice(b"0.1.0");
        frame(2, uptime_us, &args)
    }

    fn offset(uptime_us: u64) -> Vec<u8> {
        let mut args = vec![2u8];
        args.extend_from_slice(&(-37i16).to_le_bytes());
        frame(3, uptime_us, &args)
    }

    #[test]
    fn rzcobs_frames_split_across_reads_decode_with_timestamp_level_and_message() {
        let mut log = DefmtLog::new(&elf("rzcobs", &ENTRIES));
        // The logger's first separator, then three frames.
        let mut stream = vec![0];
        stream.extend(rzcobs(&up(1_234)));
        stream.extend(rzcobs(&offset(12_345_678)));
        stream.extend(rzcobs(&frame(4, 2_000_000, &[])));
        let (a, b) = stream.split_at(9);
        assert!(log.push(a, 0.001).is_empty(), "no whole frame yet");
        let got = log.push(b, 0.002).to_vec();
        assert_eq!(got.len(), 3, "{got:?}");
        assert_eq!(got[0].timestamp.as_deref(), Some("0.001234"));
        assert_eq!(got[0].level, Some("INFO"));
        assert_eq!(got[0].text, "thermorph 0.1.0 up");
        assert_eq!(got[0].at_s, 0.002);
        assert_eq!(
            got[1].to_string(),
            "  12.345678 WARN  spring channel 2: amplifier offset -37 counts"
        );
        assert_eq!(got[2].to_string(), "   2.000000 -     plain");
        assert_eq!(log.finish(0.5).len(), 3, "nothing left over");
    }

    #[test]
    fn bytes_that_are_no_frame_are_a_note_and_decoding_resumes_after_them() {
        let mut log = DefmtLog::new(&elf("rzcobs", &ENTRIES));
        let mut stream = rzcobs(&up(1));
        // An index the table does not have, then a frame cut short (a reset mid-frame: its
        // separator never written; the next boot's logger starts with one).
        stream.extend(rzcobs(&frame(99, 2, &[])));
        let cut = rzcobs(&offset(3));
        stream.extend(&cut[..4]);
        stream.push(0);
        stream.extend(rzcobs(&offset(4)));
        let got = log.push(&stream, 1.0).to_vec();
        let texts: Vec<String> = got.iter().map(|r| r.to_string()).collect();
        assert_eq!(got.len(), 4, "{texts:#?}");
        assert_eq!(texts[0], "   0.000001 INFO  thermorph 0.1.0 up");
        assert_eq!(
            texts[1],
            "    (1.000) -     undecodable defmt frame (4 bytes): not a frame of this ELF's \
             defmt table"
        );
        assert!(
            texts[2].contains("undecodable defmt frame (4 bytes)"),
            "{texts:#?}"
        );
        assert_eq!(
            texts[3],
            "   0.000004 WARN  spring channel 2: amplifier offset -37 counts"
        );
        // Garbage of every kind never stops the log.
        let mut seed = 12345u32;
        for _ in 0..2000 {
            let bytes: Vec<u8> = (0..64)
                .map(|_| {
                    seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                    (seed >> 16) as u8 % 8
                })
                .collect();
            log.push(&bytes, 2.0);
        }
        // A frame at the end with no separator yet is noted when the run ends.
        log.push(&rzcobs(&up(5))[..6], 3.0);
        let last = log.finish(3.5).pop().unwrap();
        assert!(
            last.text.ends_with("not finished by the end of the run"),
            "{last}"
        );
    }

    #[test]
    fn the_raw_encoding_decodes_frame_after_frame_and_gives_up_after_a_bad_one() {
        let mut log = DefmtLog::new(&elf("raw", &ENTRIES));
        let mut stream = up(7);
        stream.extend(offset(8));
        let (a, b) = stream.split_at(5);
        assert!(log.push(a, 0.1).is_empty());
        let got = log.push(b, 0.2).to_vec();
        assert_eq!(got.len(), 2, "{got:?}");
        assert_eq!(got[1].text, "spring channel 2: amplifier offset -37 counts");
        let got = log.push(&frame(77, 9, &[1, 2, 3]), 0.3).to_vec();
        assert_eq!(got.len(), 1);
        assert!(got[0].text.contains("13 bytes dropped"), "{}", got[0]);
        assert_eq!(log.push(&up(10), 0.4)[0].text, "thermorph 0.1.0 up");
    }

    #[test]
    fn an_elf_without_a_table_gives_one_note_for_the_bytes_it_logged() {
        let o = WObject::new(
            BinaryFormat::Elf,
            Architecture::Arm,
            object::Endianness::Little,
        );
        let mut log = DefmtLog::new(&o.write().unwrap());
        assert!(log.push(b"\x00abc\x00", 0.1).is_empty());
        assert!(log.push(b"de", 0.2).is_empty());
        let notes = log.finish(1.0);
        assert_eq!(notes.len(), 1);
        assert_eq!(
            notes[0].text,
            "7 bytes of RTT not decoded: the ELF has no .defmt table"
        );
        assert!(DefmtLog::new(b"not an elf").finish(0.0).is_empty());
    }
}
