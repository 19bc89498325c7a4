//! CAN signals: a DBC database, frames from a candump log or an MDF4 bus log, and the decoded
//! signals as channels. Parsing the DBC is can-dbc's work and bit-level decoding falcon_mdf's
//! (Intel and Motorola layouts, signs, factor and offset, multiplexing); what is ours is the
//! candump reader and the J1939 rule.
//!
//! SAE J1939 (heavy trucks): a 29-bit identifier carries priority and source address beside
//! the parameter group number (PGN), and a DBC is written against one sender. When the DBC
//! declares J1939 (`ProtocolType "J1939"` or `VFrameFormat` `J1939PG`), frames are matched on
//! the PGN whenever no message carries their exact identifier, so the same message from
//! another source address or at another priority still decodes.

use std::collections::HashMap;
use std::path::Path;

use airsus_data::{ChannelSet, DataError, DataErrorKind, Location, LogChannel, TimeBase};
use falcon_mdf::IdMatching;

/// A parsed DBC file.
pub struct CanDatabase {
    inner: falcon_mdf::CanDatabase,
    pub j1939: bool,
}

impl CanDatabase {
    pub fn read(path: &Path) -> Result<Self, DataError> {
        let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
        Self::parse(&bytes, path)
    }

    /// Parses DBC text; `path` names it in errors.
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Self, DataError> {
        let inner = falcon_mdf::CanDatabase::from_dbc(bytes).map_err(|e| {
            DataError::in_file(
                path,
                DataErrorKind::Malformed {
                    format: "DBC",
                    reason: e.to_string(),
                },
            )
        })?;
        if inner.messages().is_empty() {
            return Err(DataError::in_file(
                path,
                DataErrorKind::Malformed {
                    format: "DBC",
                    reason: "it defines no message (`BO_`)".to_owned(),
                },
            ));
        }
        let j1939 = declares_j1939(&String::from_utf8_lossy(bytes));
        let inner = if j1939 {
            inner.with_matching(IdMatching::J1939Pgn)
        } else {
            inner
        };
        Ok(Self { inner, j1939 })
    }

    /// The signals a frame carries, as (message name, signal name, unit, value).
    pub fn decode<'a>(&'a self, id: u32, data: &[u8]) -> Vec<(&'a str, &'a str, &'a str, f64)> {
        let message = self.inner.message_name(id).unwrap_or_default();
        self.inner
            .decode(id, data)
            .into_iter()
            .map(|s| (message, s.name, s.unit, s.value))
            .collect()
    }
}

/// Whether a DBC declares J1939: the database attribute `BA_ "ProtocolType" "J1939";`, the
/// message attribute `VFrameFormat` defaulting to `J1939PG` (`BA_DEF_DEF_`), or assigned the
/// `J1939PG` entry of its enum for some message (`BA_ "VFrameFormat" BO_ id N;`). The enum's
/// definition alone (Vector's template ships it in every DBC) declares nothing. can-dbc
/// parses these lines, but its attribute API differs between its versions and falcon_mdf
/// hides it; the lines are simple enough to read here.
fn declares_j1939(text: &str) -> bool {
    let quoted = |line: &str| -> Vec<String> {
        line.split('"')
            .skip(1)
            .step_by(2)
            .map(str::to_owned)
            .collect()
    };
    let mut pg_index = None;
    for line in text.lines().map(str::trim) {
        if line.starts_with("BA_DEF_ BO_") && line.contains("\"VFrameFormat\"") {
            pg_index = quoted(line)
                .iter()
                .skip(1)
                .position(|entry| entry == "J1939PG");
        }
    }
    text.lines().map(str::trim).any(|line| {
        let words = quoted(line);
        let attribute = words.first().map(String::as_str);
        if line.starts_with("BA_DEF_DEF_") {
            return attribute == Some("VFrameFormat")
                && words.get(1).is_some_and(|v| v == "J1939PG");
        }
        if !line.starts_with("BA_ ") {
            return false;
        }
        match attribute {
            Some("ProtocolType") => words.get(1).is_some_and(|v| v == "J1939"),
            Some("VFrameFormat") => {
                let value = line
                    .trim_end_matches(';')
                    .split_whitespace()
                    .last()
                    .and_then(|v| v.parse::<usize>().ok());
                value.is_some() && value == pg_index
            }
            _ => false,
        }
    })
}

/// One decoded signal over time.
pub(crate) struct Series<'a> {
    /// The message it came in, which names its time base.
    pub message: &'a str,
    pub name: &'a str,
    pub unit: &'a str,
    pub timestamps: &'a [f64],
    pub values: &'a [f64],
}

/// Adds each signal as a channel on its own time base (signals of one message share equal
/// bases, which the run builder recognises as one).
pub(crate) fn add_signals<'a>(set: &mut ChannelSet, series: impl Iterator<Item = Series<'a>>) {
    for s in series {
        let base = set.bases.len();
        set.bases.push(TimeBase {
            name: format!("frames of message `{}`", s.message),
            time_s: s.timestamps.to_vec(),
            unit: Some("s".to_owned()),
        });
        set.channels.push(LogChannel {
            name: s.name.to_owned(),
            unit: (!s.unit.trim().is_empty()).then(|| s.unit.trim().to_owned()),
            base,
            values: s.values.to_vec(),
        });
    }
}

/// One frame on its way to decoding.
pub(crate) struct FrameRef<'a> {
    /// Seconds from the log's start.
    pub time_s: f64,
    /// Which bus (interface, logger channel): the same identifier on two buses is two
    /// signals.
    pub bus: u32,
    pub id: u32,
    pub data: &'a [u8],
}

/// How the frames of a log fared.
pub(crate) struct FrameCounts {
    pub decoded: usize,
    /// Frames of messages the DBC does not define.
    pub unknown: usize,
    /// Frames of defined messages too short for their signals.
    pub short: usize,
}

impl FrameCounts {
    pub fn describe(&self) -> String {
        let mut skipped = Vec::new();
        if self.unknown > 0 {
            skipped.push(format!(
                "{} frames of messages it does not define skipped",
                self.unknown
            ));
        }
        if self.short > 0 {
            skipped.push(format!(
                "{} frames too short for their signals skipped",
                self.short
            ));
        }
        format!(
            "{} CAN frames decoded through the DBC{}",
            self.decoded,
            if skipped.is_empty() {
                String::new()
            } else {
                format!(" ({})", skipped.join(", "))
            }
        )
    }
}

/// Decodes `frames` through `database` into channels of `set`: one series per bus,
/// message, signal and (under J1939) sender, since the same signal from two buses or two
/// ECUs is two signals, which the column map then has to tell apart. The candump log and
/// MDF4 bus logging both come through here.
pub(crate) fn decode_frames<'f>(
    set: &mut ChannelSet,
    database: &CanDatabase,
    frames: impl Iterator<Item = FrameRef<'f>>,
) -> FrameCounts {
    let mut index: HashMap<(u32, &str, &str, Option<u8>), usize> = HashMap::new();
    let mut series: Vec<Readings> = Vec::new();
    let mut counts = FrameCounts {
        decoded: 0,
        unknown: 0,
        short: 0,
    };
    for frame in frames {
        let decoded = database.decode(frame.id, frame.data);
        if decoded.is_empty() {
            if database.inner.message(frame.id).is_some() {
                counts.short += 1;
            } else {
                counts.unknown += 1;
            }
            continue;
        }
        counts.decoded += 1;
        let sender = database.j1939.then_some((frame.id & 0xFF) as u8);
        for (message, signal, unit, value) in decoded {
            let k = *index
                .entry((frame.bus, message, signal, sender))
                .or_insert_with(|| {
                    series.push(Readings {
                        message,
                        name: signal,
                        unit,
                        times_s: Vec::new(),
                        values: Vec::new(),
                    });
                    series.len() - 1
                });
            series[k].times_s.push(frame.time_s);
            series[k].values.push(value);
        }
    }
    add_signals(
        set,
        series.iter().map(|r| Series {
            message: r.message,
            name: r.name,
            unit: r.unit,
            timestamps: &r.times_s,
            values: &r.values,
        }),
    );
    counts
}

/// One frame of a candump log line: `(1436509052.249713) can0 18FEF100#0102030405060708`.
struct Frame {
    /// Seconds since 1970 as the log writes them: whole seconds and nanoseconds apart, as an
    /// `f64` of epoch seconds resolves only a quarter microsecond.
    stamp: (i64, u32),
    /// The interface (`can0`): the same identifier on two buses is two signals.
    interface: String,
    id: u32,
    data: Vec<u8>,
}

fn parse_candump_line(line: &str) -> Result<Option<Frame>, String> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') || line.starts_with("//") {
        return Ok(None);
    }
    let expected = "expected `(SECONDS) INTERFACE ID#DATA`, e.g. `(1436509052.249713) can0 18FEF100#0102030405060708`";
    let mut fields = line.split_whitespace();
    let (Some(stamp), Some(interface), Some(frame)) = (fields.next(), fields.next(), fields.next())
    else {
        return Err(format!("{expected}, found `{line}`"));
    };
    let stamp = stamp
        .strip_prefix('(')
        .and_then(|s| s.strip_suffix(')'))
        .and_then(parse_stamp)
        .ok_or_else(|| format!("bad timestamp `{stamp}`: {expected}"))?;
    let Some((id_text, data_text)) = frame.split_once('#') else {
        return Err(format!(
            "no `#` between identifier and data in `{frame}`: {expected}"
        ));
    };
    if data_text.starts_with('R') {
        return Ok(None); // a remote request carries no data
    }
    // CAN FD: `ID##<flags nibble><data>`.
    let data_text = match data_text.strip_prefix('#') {
        Some(fd) if fd.bytes().next().is_some_and(|b| b.is_ascii_hexdigit()) => &fd[1..],
        Some(_) => {
            return Err(format!(
                "bad CAN FD frame `{frame}`: expected `ID##<flags><data>`"
            ));
        }
        None => data_text,
    };
    let id = u32::from_str_radix(id_text, 16)
        .ok()
        .filter(|id| *id <= 0x1FFF_FFFF && !id_text.is_empty() && id_text.len() <= 8)
        .ok_or_else(|| {
            format!("bad identifier `{id_text}`: expected 3 (standard) or 8 (extended) hex digits")
        })?;
    if data_text.len() % 2 != 0
        || data_text.len() > 128
        || !data_text.bytes().all(|b| b.is_ascii_hexdigit())
    {
        return Err(format!(
            "bad data `{data_text}`: expected up to 64 bytes as pairs of hex digits"
        ));
    }
    // Hex digits only (checked above): every pair is two ASCII bytes.
    let data = data_text
        .as_bytes()
        .chunks(2)
        .map(|pair| {
            let digit = |b: u8| (b as char).to_digit(16).unwrap_or(0) as u8;
            digit(pair[0]) << 4 | digit(pair[1])
        })
        .collect();
    Ok(Some(Frame {
        stamp,
        interface: interface.to_owned(),
        id,
        data,
    }))
}

/// `1436509052.249713` → (1436509052, 249713000): digits only, up to nanoseconds.
fn parse_stamp(text: &str) -> Option<(i64, u32)> {
    let (whole, fraction) = text.split_once('.').unwrap_or((text, ""));
    let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    if whole.is_empty() || fraction.len() > 9 || !digits(whole) || !digits(fraction) {
        return None;
    }
    // Digits only and below 2^63: two stamps never overflow when subtracted.
    let seconds: i64 = whole.parse().ok()?;
    let nanos = if fraction.is_empty() {
        0
    } else {
        fraction.parse::<u32>().ok()? * 10u32.pow(9 - fraction.len() as u32)
    };
    Some((seconds, nanos))
}

/// Seconds from `start` to `stamp`.
fn seconds_between(start: (i64, u32), stamp: (i64, u32)) -> f64 {
    (stamp.0 - start.0) as f64 + (f64::from(stamp.1) - f64::from(start.1)) * 1e-9
}

/// One signal's readings as a log is decoded.
struct Readings<'a> {
    message: &'a str,
    name: &'a str,
    unit: &'a str,
    times_s: Vec<f64>,
    values: Vec<f64>,
}

/// Reads a candump log and decodes its frames through `database`. Times count from the
/// log's first frame (candump writes seconds since 1970).
pub(crate) fn read_candump(path: &Path, database: &CanDatabase) -> Result<ChannelSet, DataError> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    let mut frames = Vec::new();
    for (index, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let location = || Location::file(path).line(index as u64 + 1);
        let line = std::str::from_utf8(line).map_err(|_| {
            DataError::new(
                location(),
                DataErrorKind::Malformed {
                    format: "candump log",
                    reason: "the line is not text (UTF-8)".to_owned(),
                },
            )
        })?;
        match parse_candump_line(line) {
            Ok(Some(frame)) => frames.push(frame),
            Ok(None) => {}
            Err(reason) => {
                return Err(DataError::new(
                    location(),
                    DataErrorKind::Malformed {
                        format: "candump log",
                        reason,
                    },
                ));
            }
        }
    }
    let Some(start) = frames.first().map(|f| f.stamp) else {
        return Err(DataError::in_file(path, DataErrorKind::Empty { needed: 2 }));
    };

    // Interfaces by number, in order of appearance.
    let mut interfaces: Vec<&str> = Vec::new();
    let refs: Vec<FrameRef> = frames
        .iter()
        .map(|frame| {
            let bus = match interfaces.iter().position(|i| *i == frame.interface) {
                Some(k) => k,
                None => {
                    interfaces.push(&frame.interface);
                    interfaces.len() - 1
                }
            };
            FrameRef {
                time_s: seconds_between(start, frame.stamp),
                bus: bus as u32,
                id: frame.id,
                data: &frame.data,
            }
        })
        .collect();
    let mut set = ChannelSet {
        format: "CAN log",
        ..ChannelSet::default()
    };
    let counts = decode_frames(&mut set, database, refs.into_iter());
    set.notes.push(format!(
        "{}; time counted from the first frame at {}.{:09} s since 1970",
        counts.describe(),
        start.0,
        start.1
    ));
    Ok(set)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candump_lines_parse_standard_extended_and_fd() {
        let f = parse_candump_line("(1436509052.249713) vcan0 18FEF100#0102030405060708 T")
            .unwrap()
            .unwrap();
        assert_eq!(f.id, 0x18FE_F100);
        assert_eq!(f.data, vec![1, 2, 3, 4, 5, 6, 7, 8]);
        assert_eq!(f.stamp, (1_436_509_052, 249_713_000));
        assert!((seconds_between((1_436_509_052, 900_000_000), f.stamp) + 0.650_287).abs() < 1e-12);
        let f = parse_candump_line("(0.5) can1 123#DEAD").unwrap().unwrap();
        assert_eq!((f.id, f.data), (0x123, vec![0xDE, 0xAD]));
        let f = parse_candump_line("(0.5) can1 123##1AABB")
            .unwrap()
            .unwrap();
        assert_eq!(f.data, vec![0xAA, 0xBB]);
        assert!(parse_candump_line("(0.5) can1 123#R").unwrap().is_none());
        assert!(parse_candump_line("").unwrap().is_none());
    }

    #[test]
    fn j1939_is_declared_by_assignment_not_by_the_enum_definition() {
        let template = "BA_DEF_ BO_ \"VFrameFormat\" ENUM \"StandardCAN\",\"ExtendedCAN\",\"reserved\",\"J1939PG\";\n";
        assert!(!declares_j1939(template));
        assert!(declares_j1939(&format!(
            "{template}BA_ \"VFrameFormat\" BO_ 2365587759 3;\n"
        )));
        assert!(!declares_j1939(&format!(
            "{template}BA_ \"VFrameFormat\" BO_ 2365587759 1;\n"
        )));
        assert!(declares_j1939(&format!(
            "{template}BA_DEF_DEF_ \"VFrameFormat\" \"J1939PG\";\n"
        )));
        assert!(declares_j1939("BA_ \"ProtocolType\" \"J1939\";\n"));
        assert!(!declares_j1939("BA_DEF_ \"ProtocolType\" STRING ;\n"));
    }

    #[test]
    fn malformed_candump_lines_say_what_was_expected() {
        for bad in [
            "0.5 can0 123#00",
            "(0.5) can0 123",
            "(0.5) can0 XYZ#00",
            "(0.5) can0 123#0",
            "(0.5) can0 123#GG",
            "(0.5) can0 3FFFFFFFF#00",
            "(nan) can0 123#00",
            "(1.-5) can0 123#00",
            "(1.0000000001) can0 123#00",
            "(-1.5) can0 123#00",
            "(0.5) can0 123#aé0",
            "(0.5) can0 123##Z00",
        ] {
            assert!(parse_candump_line(bad).is_err(), "{bad}");
        }
    }
}
