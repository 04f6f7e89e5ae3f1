//! RTKLIB stream time-tag files (`<file>.tag`, written by `str2str`/`rtknavi`
//! with the `::T` file option): when each chunk of a logged byte stream
//! arrived at the logging PC.
//!
//! Layout (RTKLIB `stream.c`, `openfile_`/`writefile`; all little-endian):
//!
//! | bytes | content |
//! |---|---|
//! | 0..60 | `"TIMETAG RTKLIB <version>"`, NUL padded |
//! | 60..64 | `tick_f`: u32 ms tick of the PC when the file was opened |
//! | 64..76 | start time, GPST counted from 1970-01-01 (RTKLIB `gtime_t`): u32 s + f64 fraction (demo5, 2.4.3 b34) |
//! | 64..80 | *or* i64 s + f64 fraction (older 2.4.2/2.4.3 builds wrote the raw 64-bit `gtime_t`) |
//! | then | records: u32 tick [ms since open] + file position after the chunk, u32 (`::P=4`, the plain layout, demo5 default) or u64 (`::P=8`, the extended layout) |
//!
//! A record `(tick, fpos)` says: the bytes up to (not including) `fpos`
//! had been received by `start + tick/1000` (the tick is taken when the
//! chunk is handed to the writer, after it was read). The layout is not
//! stored in the file; [`TagFile::read`] tries the four and keeps the one
//! whose start fraction lies in [0, 1), whose record area divides evenly and
//! whose ticks and positions never decrease (a wrong width fails these at
//! the first records: a u64 position read as u32 pairs shows a zero tick
//! after every record, u32 pairs read as u64 give positions ≥ 2³² bytes).
//!
//! The tick is the PC's millisecond counter, so receive times are only as
//! good as the PC clock rate (tens of ppm unless disciplined); the start
//! time is the PC's UTC clock converted to GPST at open.

use crate::error::ReadError;
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

/// Length of the text + `tick_f` header (RTKLIB `TIMETAGH_LEN`).
pub const TAG_HEADER_LEN: usize = 64;
/// Seconds from 1970-01-01 to the GPS epoch 1980-01-06 (3657 days).
pub const GPS_EPOCH_FROM_1970_S: f64 = 315_964_800.0;
/// The most records read (16 bytes each in memory = 256 MiB): RTKLIB writes
/// one record per received chunk, ≈ 64/s for a 15.6 ms Windows tick, so
/// this holds about 3 days of one stream. Larger files are rejected.
pub const MAX_TAG_RECORDS: u64 = 1 << 24;
const MAGIC: &[u8] = b"TIMETAG RTKLIB";

/// Width of the start-time seconds field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StartSeconds {
    /// u32 seconds + f64 fraction (12 bytes; demo5 / 2.4.3 b34).
    U32,
    /// i64 seconds + f64 fraction (16 bytes; raw 64-bit `gtime_t`).
    I64,
}

/// Width of the file-position field of a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FposWidth {
    /// u32 (`::P=4`), the plain layout.
    U32,
    /// u64 (`::P=8`), the extended layout.
    U64,
}

/// A tag file's binary layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TagLayout {
    pub start: StartSeconds,
    pub fpos: FposWidth,
}

impl TagLayout {
    /// The demo5 layout (u32 seconds, u32 positions).
    pub const PLAIN: TagLayout = TagLayout {
        start: StartSeconds::U32,
        fpos: FposWidth::U32,
    };
    /// u32 seconds, u64 positions (`::P=8`).
    pub const EXTENDED: TagLayout = TagLayout {
        start: StartSeconds::U32,
        fpos: FposWidth::U64,
    };
    /// Candidates in order of preference (the demo5 default first).
    const ALL: [TagLayout; 4] = [
        TagLayout::PLAIN,
        TagLayout::EXTENDED,
        TagLayout {
            start: StartSeconds::I64,
            fpos: FposWidth::U64,
        },
        TagLayout {
            start: StartSeconds::I64,
            fpos: FposWidth::U32,
        },
    ];
    /// Bytes before the first record.
    pub fn records_offset(&self) -> usize {
        TAG_HEADER_LEN
            + match self.start {
                StartSeconds::U32 => 12,
                StartSeconds::I64 => 16,
            }
    }
    /// Bytes per record.
    pub fn record_len(&self) -> usize {
        match self.fpos {
            FposWidth::U32 => 8,
            FposWidth::U64 => 12,
        }
    }
}

/// What is wrong with a tag file, at which byte offset.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TagError {
    #[error("byte offset {offset}: file too short for the header ({len} bytes, need {need})")]
    ShortHeader { offset: u64, len: u64, need: u64 },
    #[error("byte offset 0: not an RTKLIB time-tag file (no \"TIMETAG RTKLIB\" magic)")]
    BadMagic,
    #[error("byte offset {offset}: truncated record ({rest} bytes left over)")]
    TruncatedRecord { offset: u64, rest: u64 },
    #[error("byte offset {offset}: {what}")]
    Inconsistent { offset: u64, what: String },
    #[error("byte offset {offset}: {records} records exceed the limit of {MAX_TAG_RECORDS}")]
    TooLarge { offset: u64, records: u64 },
    #[error("byte offset {offset}: I/O error: {msg}")]
    Io { offset: u64, msg: String },
}

impl TagError {
    /// The byte offset the error refers to.
    pub fn offset(&self) -> u64 {
        match self {
            TagError::BadMagic => 0,
            TagError::ShortHeader { offset, .. }
            | TagError::TruncatedRecord { offset, .. }
            | TagError::Inconsistent { offset, .. }
            | TagError::TooLarge { offset, .. }
            | TagError::Io { offset, .. } => *offset,
        }
    }
}

/// A decoded time-tag file.
#[derive(Clone, Debug, PartialEq)]
pub struct TagFile {
    /// The header text, e.g. `TIMETAG RTKLIB demo5`.
    pub version: String,
    /// PC tick [ms] at file open (used by RTKLIB to sync replayed streams).
    pub tick_f: u32,
    /// Start time: GPS seconds since 1980-01-06 (GPST, no leap seconds).
    pub start_gps_s: f64,
    /// `(tick_ms since start, file position after the chunk)`, in file order.
    pub records: Vec<(u32, u64)>,
    pub layout: TagLayout,
}

fn le_u32(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}
fn le_u64(b: &[u8], i: usize) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[i..i + 8]);
    u64::from_le_bytes(a)
}

impl TagFile {
    /// Read and decode `path` (layout detected). Errors name the file and
    /// the byte offset (`FILE:0: field `<byte N>`: …`).
    pub fn read(path: &Path) -> Result<TagFile, ReadError> {
        let name: Arc<str> = Arc::from(path.display().to_string().as_str());
        let to_err =
            |e: TagError| ReadError::new(&name, 0, format!("<byte {}>", e.offset()), e.to_string());
        let f = std::fs::File::open(path)
            .map_err(|e| ReadError::new(&name, 0, "<file>", format!("cannot open: {e}")))?;
        let len = f
            .metadata()
            .map_err(|e| {
                to_err(TagError::Io {
                    offset: 0,
                    msg: e.to_string(),
                })
            })?
            .len();
        TagFile::decode(std::io::BufReader::new(f), len, None).map_err(to_err)
    }

    /// Decode `len` bytes from `r`; `layout` None = detect. The records are
    /// read in a streaming pass (the count is checked against
    /// [`MAX_TAG_RECORDS`] before anything is allocated).
    pub fn decode<R: Read>(
        mut r: R,
        len: u64,
        layout: Option<TagLayout>,
    ) -> Result<TagFile, TagError> {
        // The prefix used to tell the layouts apart: header, start time and
        // up to 64 records.
        let mut head = [0u8; DETECT_PREFIX];
        let n_head = (len.min(head.len() as u64)) as usize;
        r.read_exact(&mut head[..n_head])
            .map_err(|e| TagError::Io {
                offset: 0,
                msg: e.to_string(),
            })?;
        let head = &head[..n_head];
        if n_head < MAGIC.len() || &head[..MAGIC.len()] != MAGIC {
            return Err(if n_head < TAG_HEADER_LEN && MAGIC.starts_with(head) {
                TagError::ShortHeader {
                    offset: len,
                    len,
                    need: 76,
                }
            } else {
                TagError::BadMagic
            });
        }
        if len < 76 {
            return Err(TagError::ShortHeader {
                offset: len,
                len,
                need: 76,
            });
        }
        let layout = match layout {
            Some(l) => l,
            None => detect(head, len)?,
        };
        let off = layout.records_offset() as u64;
        if len < off {
            return Err(TagError::ShortHeader {
                offset: len,
                len,
                need: off,
            });
        }
        let (secs, frac) = match layout.start {
            StartSeconds::U32 => (
                le_u32(head, 64) as f64,
                f64::from_le_bytes(head[68..76].try_into().unwrap()),
            ),
            StartSeconds::I64 => (
                le_u64(head, 64) as i64 as f64,
                f64::from_le_bytes(head[72..80].try_into().unwrap()),
            ),
        };
        if !(0.0..1.0).contains(&frac) {
            return Err(TagError::Inconsistent {
                offset: off - 8,
                what: format!("start-time fraction {frac} outside [0, 1)"),
            });
        }
        let start_gps_s = secs - GPS_EPOCH_FROM_1970_S + frac;
        let rl = layout.record_len() as u64;
        let body = len - off;
        let count = body / rl;
        if count > MAX_TAG_RECORDS {
            return Err(TagError::TooLarge {
                offset: off,
                records: count,
            });
        }
        if !body.is_multiple_of(rl) {
            return Err(TagError::TruncatedRecord {
                offset: off + count * rl,
                rest: body % rl,
            });
        }
        let version = String::from_utf8_lossy(&head[..60])
            .trim_end_matches('\0')
            .trim_end()
            .to_string();
        let tick_f = le_u32(head, 60);
        // Stream the records: the prefix already read, then the rest.
        let mut records = Vec::with_capacity(count as usize);
        let end = off + count * rl;
        let mut pending: Vec<u8> =
            head[(off as usize).min(n_head)..(end as usize).min(n_head)].to_vec();
        let mut read_to = (n_head as u64).min(end).max(off);
        let mut buf = vec![0u8; 1 << 16];
        let mut at = off;
        let (mut last_tick, mut last_pos) = (0u32, 0u64);
        while (records.len() as u64) < count {
            if pending.len() < rl as usize {
                let want = (end - read_to).min(buf.len() as u64) as usize;
                r.read_exact(&mut buf[..want]).map_err(|e| TagError::Io {
                    offset: read_to,
                    msg: e.to_string(),
                })?;
                read_to += want as u64;
                pending.extend_from_slice(&buf[..want]);
            }
            let mut i = 0;
            while i + rl as usize <= pending.len() {
                let tick = le_u32(&pending, i);
                let pos = match layout.fpos {
                    FposWidth::U32 => le_u32(&pending, i + 4) as u64,
                    FposWidth::U64 => le_u64(&pending, i + 4),
                };
                if pos < last_pos || tick.wrapping_sub(last_tick) > u32::MAX / 2 {
                    return Err(TagError::Inconsistent {
                        offset: at,
                        what: format!(
                            "record {} goes backwards: tick {tick} ms, position {pos} after tick {last_tick} ms, position {last_pos}",
                            records.len()
                        ),
                    });
                }
                (last_tick, last_pos) = (tick, pos);
                records.push((tick, pos));
                i += rl as usize;
                at += rl;
            }
            pending.drain(..i);
        }
        Ok(TagFile {
            version,
            tick_f,
            start_gps_s,
            records,
            layout,
        })
    }

    /// GPS time [s since 1980-01-06] at which the byte at `file_pos` of the
    /// logged file had been received: the time of the first record whose
    /// chunk ends after `file_pos` (held over the chunk, no interpolation:
    /// the whole chunk was handed over at that tick). None past the last
    /// record (those bytes have no receive time).
    pub fn receive_time_at(&self, file_pos: u64) -> Option<f64> {
        let k = self.records.partition_point(|&(_, p)| p <= file_pos);
        self.records
            .get(k)
            .map(|&(tick, _)| self.start_gps_s + tick as f64 * 1e-3)
    }

    /// File position after the last recorded chunk (0 without records).
    pub fn end_pos(&self) -> u64 {
        self.records.last().map_or(0, |r| r.1)
    }
}

/// Bytes read before the layout is chosen: header, start time, 64 records.
const DETECT_PREFIX: usize = 80 + 64 * 12;

/// Whether layout `l` fits the prefix `head` of a `len`-byte file: start
/// fraction in [0, 1), the first record's position below 2³² (a first chunk
/// is small; a u32 pair read as u64 puts the next tick in the high word),
/// and ticks and positions never decreasing over the prefix. Divisibility of
/// the record area is reported separately (a truncated file still fits).
fn fits(l: &TagLayout, head: &[u8], len: u64) -> Option<bool> {
    let off = l.records_offset();
    if len < off as u64 || head.len() < off {
        return None;
    }
    let frac = match l.start {
        StartSeconds::U32 => f64::from_le_bytes(head[68..76].try_into().ok()?),
        StartSeconds::I64 => {
            if le_u32(head, 68) != 0 {
                return None;
            }
            f64::from_le_bytes(head[72..80].try_into().ok()?)
        }
    };
    if !(0.0..1.0).contains(&frac) {
        return None;
    }
    let rl = l.record_len();
    let mut prev = (0u32, 0u64);
    let mut i = off;
    while i + rl <= head.len() {
        let p = match l.fpos {
            FposWidth::U32 => le_u32(head, i + 4) as u64,
            FposWidth::U64 => le_u64(head, i + 4),
        };
        let rec = (le_u32(head, i), p);
        if (i == off && p >= 1 << 32) || rec.0 < prev.0 || rec.1 < prev.1 {
            return None;
        }
        prev = rec;
        i += rl;
    }
    Some((len - off as u64).is_multiple_of(rl as u64))
}

/// The first candidate layout that fits; a layout that fits all but the
/// record-area length means a truncated last record.
fn detect(head: &[u8], len: u64) -> Result<TagLayout, TagError> {
    let verdicts = TagLayout::ALL.map(|l| (l, fits(&l, head, len)));
    if let Some((l, _)) = verdicts.iter().find(|v| v.1 == Some(true)) {
        return Ok(*l);
    }
    match verdicts.iter().find(|v| v.1 == Some(false)) {
        Some((l, _)) => {
            let (off, rl) = (l.records_offset() as u64, l.record_len() as u64);
            let rest = (len - off) % rl;
            Err(TagError::TruncatedRecord { offset: len - rest, rest })
        }
        None => Err(TagError::Inconsistent {
            offset: 64,
            what: "no known layout fits (start-time fraction outside [0, 1) or records going backwards)"
                .to_string(),
        }),
    }
}

/// Encode a tag file (tests and tools: the inverse of [`TagFile::decode`]).
pub fn encode(t: &TagFile) -> Vec<u8> {
    let mut v = vec![0u8; TAG_HEADER_LEN];
    let n = t.version.len().min(60);
    v[..n].copy_from_slice(&t.version.as_bytes()[..n]);
    v[60..64].copy_from_slice(&t.tick_f.to_le_bytes());
    let s1970 = t.start_gps_s + GPS_EPOCH_FROM_1970_S;
    let secs = s1970.floor();
    match t.layout.start {
        StartSeconds::U32 => v.extend_from_slice(&(secs as u32).to_le_bytes()),
        StartSeconds::I64 => v.extend_from_slice(&(secs as i64).to_le_bytes()),
    }
    v.extend_from_slice(&(s1970 - secs).to_le_bytes());
    for &(tick, pos) in &t.records {
        v.extend_from_slice(&tick.to_le_bytes());
        match t.layout.fpos {
            FposWidth::U32 => v.extend_from_slice(&(pos as u32).to_le_bytes()),
            FposWidth::U64 => v.extend_from_slice(&pos.to_le_bytes()),
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(layout: TagLayout) -> TagFile {
        TagFile {
            version: "TIMETAG RTKLIB demo5".to_string(),
            tick_f: 1_132_617_148,
            start_gps_s: 1_436_038_461.854,
            records: (0..200u32)
                .map(|k| (131 + 15 * k, 37 + 62 * k as u64))
                .collect(),
            layout,
        }
    }

    #[test]
    fn round_trip_in_every_layout_with_detection() {
        for l in TagLayout::ALL {
            let t = sample(l);
            let b = encode(&t);
            let d = TagFile::decode(&b[..], b.len() as u64, None).unwrap();
            assert_eq!(d.layout, l);
            assert_eq!(
                (&d.version, d.tick_f, &d.records),
                (&t.version, t.tick_f, &t.records)
            );
            assert!((d.start_gps_s - t.start_gps_s).abs() < 1e-6);
        }
    }

    #[test]
    fn receive_time_holds_the_chunk_time() {
        let t = sample(TagLayout::PLAIN);
        assert_eq!(t.receive_time_at(0), Some(t.start_gps_s + 0.131));
        assert_eq!(t.receive_time_at(36), Some(t.start_gps_s + 0.131));
        assert_eq!(t.receive_time_at(37), Some(t.start_gps_s + 0.146));
        assert_eq!(t.receive_time_at(t.end_pos()), None);
    }

    #[test]
    fn corrupt_files_are_errors_with_offsets() {
        let b = encode(&sample(TagLayout::PLAIN));
        let dec = |b: &[u8]| TagFile::decode(b, b.len() as u64, None);
        assert!(matches!(dec(&b[..40]), Err(TagError::ShortHeader { .. })));
        let mut bad = b.clone();
        bad[0] = b'X';
        assert_eq!(dec(&bad), Err(TagError::BadMagic));
        let e = dec(&b[..b.len() - 3]).unwrap_err();
        assert_eq!(
            e,
            TagError::TruncatedRecord {
                offset: (b.len() - 8) as u64,
                rest: 5
            }
        );
        // A position going backwards in the middle.
        let mut back = b.clone();
        back[76 + 8 * 150 + 4..76 + 8 * 150 + 8].copy_from_slice(&1u32.to_le_bytes());
        let e = dec(&back).unwrap_err();
        assert_eq!(e.offset(), 76 + 8 * 150, "{e}");
        // An absurd size is rejected before allocating.
        let e = TagFile::decode(
            &b[..],
            76 + 8 * (MAX_TAG_RECORDS + 1),
            Some(TagLayout::PLAIN),
        )
        .unwrap_err();
        assert!(matches!(e, TagError::TooLarge { .. }), "{e}");
        // Through `read`: the error names the file and the byte offset.
        let p = std::env::temp_dir().join(format!("navfuse_tag_{}.tag", std::process::id()));
        std::fs::write(&p, &b[..b.len() - 3]).unwrap();
        let e = TagFile::read(&p).unwrap_err();
        std::fs::remove_file(&p).ok();
        assert!(
            e.to_string()
                .contains(&format!("field `<byte {}>`", b.len() - 8)),
            "{e}"
        );
        assert!(e.file.ends_with(".tag"));
    }
}
