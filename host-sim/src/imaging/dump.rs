//! Sensor dump files: the text format of `shared/data/mlx90640/SOURCES.md`.
//!
//! One 16-bit word per token, hexadecimal, whitespace separated, `#` starts a comment. An
//! EEPROM file holds 832 words (0x2400–0x273F); a frame file 834 words (RAM 0x0400–0x073F, the
//! control register, the subpage number), the layout of the library's `MLX90640_GetFrameData`.
//!
//! This module owns the error types of dump files: [`DumpError`] (a refused file, named) and
//! [`BadWord`] (a token that is not a 16-bit word).

use std::fmt;
use std::path::Path;

use thermorph::mlx90640::{EEPROM_WORDS, FRAME_WORDS, SubpageFrame};

/// Why a dump file was refused; `Display` names the file.
#[derive(Debug)]
pub struct DumpError {
    /// The file.
    pub path: String,
    /// What is wrong with it.
    pub reason: String,
}

impl fmt::Display for DumpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path, self.reason)
    }
}

impl std::error::Error for DumpError {}

/// A token of a dump text that is not a 16-bit hex word.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("line {line}: `{token}` is not a 16-bit hex word")]
pub struct BadWord {
    /// The line, 1-based.
    pub line: usize,
    /// The token.
    pub token: String,
}

/// Parse the words of a dump text; `Err` says which token is wrong.
pub fn parse_words(text: &str) -> Result<Vec<u16>, BadWord> {
    let mut words = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let content = line.split('#').next().unwrap_or("");
        for tok in content.split_whitespace() {
            let digits = tok
                .strip_prefix("0x")
                .or_else(|| tok.strip_prefix("0X"))
                .unwrap_or(tok);
            let bad = || BadWord {
                line: n + 1,
                token: tok.to_string(),
            };
            if digits.is_empty() || digits.len() > 4 {
                return Err(bad());
            }
            let w = u16::from_str_radix(digits, 16).map_err(|_| bad())?;
            words.push(w);
        }
    }
    Ok(words)
}

fn read_exact(path: &Path, expected: usize, what: &str) -> Result<Vec<u16>, DumpError> {
    let err = |reason: String| DumpError {
        path: path.display().to_string(),
        reason,
    };
    let text = std::fs::read_to_string(path).map_err(|e| err(format!("cannot read: {e}")))?;
    let words = parse_words(&text).map_err(|e| err(e.to_string()))?;
    if words.len() != expected {
        return Err(err(format!(
            "{what} needs {expected} words, the file has {}",
            words.len()
        )));
    }
    Ok(words)
}

/// Read an EEPROM dump (832 words).
pub fn read_eeprom(path: &Path) -> Result<[u16; EEPROM_WORDS], DumpError> {
    let w = read_exact(path, EEPROM_WORDS, "an EEPROM dump")?;
    let mut out = [0u16; EEPROM_WORDS];
    out.copy_from_slice(&w);
    Ok(out)
}

/// Read a frame dump (834 words).
pub fn read_frame(path: &Path) -> Result<SubpageFrame, DumpError> {
    let w = read_exact(path, FRAME_WORDS, "a frame dump")?;
    let mut f = SubpageFrame::new();
    f.words.copy_from_slice(&w);
    if f.words[FRAME_WORDS - 1] > 1 {
        return Err(DumpError {
            path: path.display().to_string(),
            reason: format!(
                "the last word is the subpage number and must be 0 or 1, not {}",
                f.words[FRAME_WORDS - 1]
            ),
        });
    }
    Ok(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_words_and_comments() {
        assert_eq!(
            parse_words("# head\n00AE 0x499a\n  FFFF # tail\n").unwrap(),
            vec![0x00AE, 0x499A, 0xFFFF]
        );
        assert!(
            parse_words("12345")
                .unwrap_err()
                .to_string()
                .contains("line 1")
        );
        assert!(
            parse_words("00AE\nzz")
                .unwrap_err()
                .to_string()
                .contains("line 2")
        );
        assert!(parse_words("0x").is_err());
    }
}
