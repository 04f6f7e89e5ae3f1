//! Line-by-line tokenizer shared by the text readers: one reused byte buffer,
//! fields as byte ranges, UTF-8 checked per field (so a non-UTF-8 byte is
//! reported against the field it sits in), numbers parsed from `&str`.

use crate::error::{ReadError, RecordStats};
use std::borrow::Cow;
use std::io::{self, BufRead};
use std::path::Path;
use std::sync::Arc;

/// The longest line any text reader accepts, in bytes (1 MiB; the
/// terminator not counted). The longest legitimate lines navfuse reads are a
/// few hundred bytes (a CSV IMU row, an NMEA sentence ≤ 82 by the standard,
/// RINEX ≤ 80), so 1 MiB rejects only garbage while bounding the memory a
/// malformed file (no newline at all) can take: a longer line is never held,
/// it is read in buffer-sized chunks and skipped.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Largest configuration file (run TOML, KF-GINS YAML, scenario) read, in
/// bytes: 16 MiB, a thousand times the largest real one (a few kB).
pub const MAX_CONFIG_BYTES: u64 = 16 << 20;

/// The message of a line over [`MAX_LINE_BYTES`].
pub fn too_long_msg() -> String {
    format!("line longer than {MAX_LINE_BYTES} bytes")
}

/// How [`fill_line`] ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fill {
    /// No byte left.
    Eof,
    /// A line (with its `\n` when present) is in the buffer.
    Line,
    /// More than `max` bytes without a newline: the buffer holds nothing
    /// useful and the rest of the line is unread (see [`skip_line`]).
    TooLong,
}

/// Append one line of `r` to `buf` (with its `\n`), keeping at most `max`
/// bytes (plus `\r\n`). Reads in the `BufRead`'s chunks, so memory stays
/// bounded by `max` whatever the input.
pub fn fill_line<R: BufRead + ?Sized>(
    r: &mut R,
    buf: &mut Vec<u8>,
    max: usize,
) -> io::Result<Fill> {
    let start = buf.len();
    loop {
        let avail = match r.fill_buf() {
            Ok(a) => a,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if avail.is_empty() {
            return Ok(if buf.len() == start {
                Fill::Eof
            } else {
                Fill::Line
            });
        }
        let held = buf.len() - start;
        let (take, done) = match avail.iter().position(|&b| b == b'\n') {
            Some(i) => (i + 1, true),
            None => (avail.len(), false),
        };
        // At most `max` content bytes: a complete line without its `\r\n`;
        // an incomplete one may still end in a `\r` before its `\n`.
        let too_long = if done {
            let cr = if take >= 2 {
                avail[take - 2] == b'\r'
            } else {
                held > 0 && buf.last() == Some(&b'\r')
            };
            held + take - 1 - cr as usize > max
        } else {
            held + take > max + 1
        };
        if too_long {
            // Nothing of this chunk consumed: `skip_line` goes on from here.
            buf.truncate(start);
            return Ok(Fill::TooLong);
        }
        buf.extend_from_slice(&avail[..take]);
        r.consume(take);
        if done {
            return Ok(Fill::Line);
        }
    }
}

/// Consume `r` through the next `\n` (or to the end) without keeping it.
pub fn skip_line<R: BufRead + ?Sized>(r: &mut R) -> io::Result<()> {
    loop {
        let avail = match r.fill_buf() {
            Ok(a) => a,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if avail.is_empty() {
            return Ok(());
        }
        match avail.iter().position(|&b| b == b'\n') {
            Some(i) => {
                r.consume(i + 1);
                return Ok(());
            }
            None => {
                let n = avail.len();
                r.consume(n);
            }
        }
    }
}

/// `BufRead::lines` with the [`MAX_LINE_BYTES`] bound: a longer line is
/// skipped and yields an `InvalidData` error "line longer than … bytes";
/// invalid UTF-8 is an `InvalidData` error as in `lines`. The line is
/// without its `\n`/`\r\n`.
pub struct CappedLines<R> {
    r: R,
    buf: Vec<u8>,
}

/// [`CappedLines`] over `r`.
pub fn capped_lines<R: BufRead>(r: R) -> CappedLines<R> {
    CappedLines {
        r,
        buf: Vec::with_capacity(256),
    }
}

impl<R: BufRead> Iterator for CappedLines<R> {
    type Item = io::Result<String>;
    fn next(&mut self) -> Option<Self::Item> {
        self.buf.clear();
        match fill_line(&mut self.r, &mut self.buf, MAX_LINE_BYTES) {
            Err(e) => Some(Err(e)),
            Ok(Fill::Eof) => None,
            Ok(Fill::TooLong) => Some(skip_line(&mut self.r).and(Err(io::Error::new(
                io::ErrorKind::InvalidData,
                too_long_msg(),
            )))),
            Ok(Fill::Line) => {
                while matches!(self.buf.last(), Some(b'\n' | b'\r')) {
                    self.buf.pop();
                }
                Some(
                    String::from_utf8(std::mem::take(&mut self.buf))
                        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e)),
                )
            }
        }
    }
}

/// Read the file `path` whole, for the formats parsed as a whole
/// (configuration, RINEX, almanacs): at most `max_bytes` bytes (checked
/// before reading, and while reading for non-regular files) and no line over
/// [`MAX_LINE_BYTES`]; the error names the file and the line. Memory is
/// bounded by `max_bytes` and by the well-formed lines read, never by one
/// malformed line.
pub fn read_bytes_capped(path: &Path, max_bytes: u64) -> Result<Vec<u8>, ReadError> {
    read_capped(path, max_bytes, false)
}

/// [`read_bytes_capped`] as UTF-8 text (a line that is not is an error naming it).
pub fn read_text_capped(path: &Path, max_bytes: u64) -> Result<String, ReadError> {
    let b = read_capped(path, max_bytes, true)?;
    Ok(String::from_utf8(b).expect("every line checked"))
}

fn read_capped(path: &Path, max_bytes: u64, utf8: bool) -> Result<Vec<u8>, ReadError> {
    use std::io::Read as _;
    let (rdr, name) = crate::open(path)?;
    let file: Arc<str> = Arc::from(name.as_str());
    let too_big = || {
        ReadError::new(
            &file,
            0,
            "<file>",
            format!("larger than {max_bytes} bytes: not read"),
        )
    };
    if rdr.get_ref().metadata().is_ok_and(|m| m.len() > max_bytes) {
        return Err(too_big());
    }
    let mut r = rdr.take(max_bytes.saturating_add(1));
    let mut out = Vec::new();
    let mut line = 0u64;
    loop {
        let at = out.len();
        let err = |line: u64, msg: String| ReadError::new(&file, line, "<line>", msg);
        match fill_line(&mut r, &mut out, MAX_LINE_BYTES) {
            Err(e) => return Err(err(line + 1, format!("I/O error: {e}"))),
            Ok(Fill::Eof) => break,
            Ok(Fill::TooLong) => return Err(err(line + 1, too_long_msg())),
            Ok(Fill::Line) => {
                line += 1;
                if utf8 && std::str::from_utf8(&out[at..]).is_err() {
                    return Err(err(line, "not valid UTF-8".into()));
                }
            }
        }
        if out.len() as u64 > max_bytes {
            return Err(too_big());
        }
    }
    Ok(out)
}

/// How fields are separated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sep {
    /// Runs of spaces/tabs (KF-GINS text, RTKLIB .pos).
    Whitespace,
    /// A single byte, e.g. `b','`; fields are trimmed of spaces/tabs.
    Byte(u8),
}

/// Streaming line source over a `BufRead`.
pub struct LineSource<R> {
    rdr: R,
    pub(crate) file: Arc<str>,
    buf: Vec<u8>,
    spans: Vec<(usize, usize)>,
    pub(crate) line_no: u64,
    terminated: bool,
    eof: bool,
    /// The previous line was over [`MAX_LINE_BYTES`] and its rest is unread.
    skip_rest: bool,
    pub(crate) stats: RecordStats,
}

/// The shared iterator step of the record readers: a record is counted as
/// used; the end of input or the first error ends the stream.
pub(crate) fn record_step<T>(
    r: Result<Option<T>, ReadError>,
    done: &mut bool,
    stats: &mut RecordStats,
) -> Option<Result<T, ReadError>> {
    match r {
        Ok(Some(x)) => {
            stats.used += 1;
            Some(Ok(x))
        }
        Ok(None) => {
            *done = true;
            None
        }
        Err(e) => {
            *done = true;
            Some(Err(e))
        }
    }
}

fn is_ws(b: u8) -> bool {
    b == b' ' || b == b'\t'
}

impl<R: BufRead> LineSource<R> {
    pub fn new(rdr: R, file: impl Into<Arc<str>>) -> Self {
        LineSource {
            rdr,
            file: file.into(),
            buf: Vec::with_capacity(256),
            spans: Vec::with_capacity(64),
            line_no: 0,
            terminated: true,
            eof: false,
            skip_rest: false,
            stats: RecordStats::default(),
        }
    }

    /// Read the next line into the buffer (without `\r\n`). `Ok(false)` at EOF.
    /// A line over [`MAX_LINE_BYTES`] is an error `FILE:LINE: line longer than
    /// … bytes`, counted as rejected (`line too long`); it is never held in
    /// memory (its rest is skipped in chunks if reading goes on).
    pub fn next_line(&mut self) -> Result<bool, ReadError> {
        if self.eof {
            return Ok(false);
        }
        self.buf.clear();
        self.spans.clear();
        let io_err = |s: &mut Self, e: io::Error| {
            s.eof = true;
            ReadError::new(&s.file, s.line_no + 1, "<line>", format!("I/O error: {e}"))
        };
        if self.skip_rest {
            self.skip_rest = false;
            if let Err(e) = skip_line(&mut self.rdr) {
                return Err(io_err(self, e));
            }
        }
        let fill = match fill_line(&mut self.rdr, &mut self.buf, MAX_LINE_BYTES) {
            Ok(f) => f,
            Err(e) => return Err(io_err(self, e)),
        };
        match fill {
            Fill::Eof => {
                self.eof = true;
                return Ok(false);
            }
            Fill::TooLong => {
                self.line_no += 1;
                self.stats.lines += 1;
                self.stats.reject("line too long");
                self.skip_rest = true;
                return Err(self.err("<line>", too_long_msg()));
            }
            Fill::Line => {}
        }
        self.line_no += 1;
        self.stats.lines += 1;
        self.terminated = self.buf.last() == Some(&b'\n');
        while matches!(self.buf.last(), Some(b'\n' | b'\r')) {
            self.buf.pop();
        }
        Ok(true)
    }

    /// The raw bytes of the current line.
    pub fn bytes(&self) -> &[u8] {
        &self.buf
    }

    /// Whether the current line is empty or only whitespace.
    pub fn is_blank(&self) -> bool {
        self.buf.iter().all(|&b| is_ws(b))
    }

    /// Whether the first non-blank byte of the line is `c`.
    pub fn starts_with(&self, c: u8) -> bool {
        self.buf.iter().find(|&&b| !is_ws(b)) == Some(&c)
    }

    /// Whether the current line is the last one and lacks its `\n`
    /// (a file cut off while being written).
    pub fn is_unterminated_last(&self) -> bool {
        !self.terminated
    }

    /// Split the current line into fields.
    pub fn split(&mut self, sep: Sep) {
        self.spans.clear();
        let b = &self.buf;
        match sep {
            Sep::Whitespace => {
                let mut i = 0;
                while i < b.len() {
                    while i < b.len() && is_ws(b[i]) {
                        i += 1;
                    }
                    if i >= b.len() {
                        break;
                    }
                    let s = i;
                    while i < b.len() && !is_ws(b[i]) {
                        i += 1;
                    }
                    self.spans.push((s, i));
                }
            }
            Sep::Byte(c) => {
                let mut s = 0;
                for i in 0..=b.len() {
                    if i == b.len() || b[i] == c {
                        let (mut a, mut e) = (s, i);
                        while a < e && is_ws(b[a]) {
                            a += 1;
                        }
                        while e > a && is_ws(b[e - 1]) {
                            e -= 1;
                        }
                        self.spans.push((a, e));
                        s = i + 1;
                    }
                }
            }
        }
    }

    /// Split after skipping `skip` leading bytes (e.g. a comment marker).
    pub fn split_from(&mut self, skip: usize, sep: Sep) {
        let skip = skip.min(self.buf.len());
        self.buf.drain(..skip);
        self.split(sep);
    }

    /// Number of fields of the current line.
    pub fn n_fields(&self) -> usize {
        self.spans.len()
    }

    /// An error at the current line.
    pub fn err(&self, field: impl Into<Cow<'static, str>>, msg: impl Into<String>) -> ReadError {
        ReadError::new(&self.file, self.line_no, field, msg)
    }

    /// Require exactly `names.len()` fields (or at least, when `allow_extra`);
    /// the error names the first missing field or the first extra column.
    pub fn expect_fields(
        &self,
        names: &[&'static str],
        allow_extra: bool,
    ) -> Result<(), ReadError> {
        let n = self.n_fields();
        if n < names.len() {
            return Err(self.err(
                names[n],
                format!(
                    "missing (line has {n} columns, expected {}{})",
                    names.len(),
                    if allow_extra { " or more" } else { "" }
                ),
            ));
        }
        if !allow_extra && n > names.len() {
            return Err(self.err(
                format!("<column {}>", names.len() + 1),
                format!(
                    "unexpected extra column (line has {n} columns, expected {})",
                    names.len()
                ),
            ));
        }
        Ok(())
    }

    /// Field `i` as text (UTF-8 checked). Missing field → error naming `name`.
    pub fn text(&self, i: usize, name: &'static str) -> Result<&str, ReadError> {
        let &(a, e) = self.spans.get(i).ok_or_else(|| {
            self.err(
                name,
                format!("missing (line has {} columns)", self.spans.len()),
            )
        })?;
        std::str::from_utf8(&self.buf[a..e]).map_err(|_| {
            self.err(
                name,
                format!(
                    "not valid UTF-8: {:?}",
                    String::from_utf8_lossy(&self.buf[a..e])
                ),
            )
        })
    }

    /// Field `i` as text with a runtime name (CSV columns from a header).
    pub fn text_named(&self, i: usize, name: &str) -> Result<&str, ReadError> {
        self.text(i, "").map_err(|mut e| {
            e.field = Cow::Owned(name.to_string());
            e
        })
    }

    /// Field `i` as a finite `f64`, with a runtime field name (CSV header names).
    pub fn f64_named(&self, i: usize, name: &str) -> Result<f64, ReadError> {
        let s = self.text_named(i, name)?;
        parse_finite(s).map_err(|m| self.err(name.to_string(), m))
    }

    /// Field `i` as a finite `f64`.
    pub fn f64(&self, i: usize, name: &'static str) -> Result<f64, ReadError> {
        let s = self.text(i, name)?;
        parse_finite(s).map_err(|m| self.err(name, m))
    }

    /// Field `i` as an `f64` that may be NaN (`nan`, any case) but not ±inf.
    pub fn f64_or_nan(&self, i: usize, name: &'static str) -> Result<f64, ReadError> {
        let s = self.text(i, name)?;
        match s.parse::<f64>() {
            Ok(v) if v.is_nan() => Ok(f64::NAN),
            _ => parse_finite(s).map_err(|m| self.err(name, m)),
        }
    }
}

/// Parse a finite `f64`; the error text quotes the input.
pub fn parse_finite(s: &str) -> Result<f64, String> {
    if s.is_empty() {
        return Err("empty".into());
    }
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("not a finite number: {s:?}")),
        Err(_) => Err(format!("not a number: {s:?}")),
    }
}

/// Check that `v` is in `[lo, hi]`; error text names the range.
pub fn in_range(v: f64, lo: f64, hi: f64, what: &str) -> Result<f64, String> {
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{what} {v} outside [{lo}, {hi}]"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_and_reports_fields() {
        let data = b"1 2\t 3\r\n4,, 5 \nx";
        let mut s = LineSource::new(&data[..], "t.txt");
        assert!(s.next_line().unwrap());
        s.split(Sep::Whitespace);
        assert_eq!(s.n_fields(), 3);
        assert_eq!(s.f64(2, "c").unwrap(), 3.0);
        assert!(s.next_line().unwrap());
        s.split(Sep::Byte(b','));
        assert_eq!(s.n_fields(), 3);
        assert_eq!(s.text(1, "b").unwrap(), "");
        let e = s.f64(1, "b").unwrap_err();
        assert_eq!(e.to_string(), "t.txt:2: field `b`: empty");
        assert_eq!(s.text(2, "c").unwrap(), "5");
        assert!(s.next_line().unwrap());
        assert!(s.is_unterminated_last());
        assert!(!s.next_line().unwrap());
        assert_eq!(s.stats.lines, 3);
    }

    #[test]
    fn overlong_line_is_rejected_without_being_held() {
        let mut data = b"1 2\n".to_vec();
        data.extend(std::iter::repeat_n(b'x', 3 * MAX_LINE_BYTES));
        data.extend_from_slice(b"\n3 4\n");
        // A small BufReader: the long line passes through in 4 KiB chunks.
        let mut s = LineSource::new(
            std::io::BufReader::with_capacity(4096, &data[..]),
            "big.txt",
        );
        assert!(s.next_line().unwrap());
        let e = s.next_line().unwrap_err();
        assert_eq!(
            e.to_string(),
            "big.txt:2: field `<line>`: line longer than 1048576 bytes"
        );
        // Vec growth doubles: at most twice the bound, never the line.
        assert!(
            s.buf.capacity() <= 2 * (MAX_LINE_BYTES + 4096),
            "{}",
            s.buf.capacity()
        );
        assert!(
            s.next_line().unwrap(),
            "reading goes on after the long line"
        );
        s.split(Sep::Whitespace);
        assert_eq!(s.f64(1, "b").unwrap(), 4.0);
        assert_eq!(s.line_no, 3);
        assert_eq!(s.stats.rejected_for("line too long"), 1);
        // Exactly at the bound is accepted, with `\r\n`.
        let mut ok = vec![b'7'; MAX_LINE_BYTES];
        ok.extend_from_slice(b"\r\n");
        let mut s = LineSource::new(&ok[..], "edge.txt");
        assert!(s.next_line().unwrap());
        assert_eq!(s.bytes().len(), MAX_LINE_BYTES);
    }

    #[test]
    fn capped_lines_and_capped_text() {
        let mut data = vec![b'y'; MAX_LINE_BYTES + 1];
        data.extend_from_slice(b"\nok\r\n");
        let v: Vec<_> = capped_lines(&data[..]).collect();
        assert_eq!(v.len(), 2);
        assert!(v[0]
            .as_ref()
            .unwrap_err()
            .to_string()
            .contains("longer than 1048576"));
        assert_eq!(v[1].as_ref().unwrap(), "ok");
        let d = std::env::temp_dir().join(format!("navfuse_text_{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join("a.toml");
        std::fs::write(&p, "a = 1\nb = 2\n").unwrap();
        assert_eq!(read_text_capped(&p, 100).unwrap(), "a = 1\nb = 2\n");
        let e = read_text_capped(&p, 5).unwrap_err().to_string();
        assert!(e.contains("larger than 5 bytes"), "{e}");
        std::fs::write(&p, &data).unwrap();
        let e = read_text_capped(&p, u64::MAX).unwrap_err().to_string();
        assert!(e.contains(":1: field `<line>`: line longer than"), "{e}");
        std::fs::write(&p, b"ok\n\xff\n").unwrap();
        let e = read_text_capped(&p, 100).unwrap_err().to_string();
        assert!(e.contains(":2: field `<line>`: not valid UTF-8"), "{e}");
    }

    #[test]
    fn nan_and_inf_policy() {
        let mut s = LineSource::new(&b"nan NaN inf 1e400\n"[..], "f");
        s.next_line().unwrap();
        s.split(Sep::Whitespace);
        assert!(s.f64_or_nan(0, "a").unwrap().is_nan());
        assert!(s.f64_or_nan(1, "a").unwrap().is_nan());
        assert!(s.f64(0, "a").unwrap_err().msg.contains("finite"));
        assert!(s.f64_or_nan(2, "a").is_err());
        assert!(s.f64(3, "a").is_err());
    }
}
