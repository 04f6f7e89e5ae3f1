//! Line-by-line tokenizer shared by the text readers: one reused byte buffer,
//! fields as byte ranges, UTF-8 checked per field (so a non-UTF-8 byte is
//! reported against the field it sits in), numbers parsed from `&str`.

use crate::error::{ReadError, RecordStats};
use std::borrow::Cow;
use std::io::BufRead;
use std::sync::Arc;

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
            stats: RecordStats::default(),
        }
    }

    /// Read the next line into the buffer (without `\r\n`). `Ok(false)` at EOF.
    pub fn next_line(&mut self) -> Result<bool, ReadError> {
        if self.eof {
            return Ok(false);
        }
        self.buf.clear();
        self.spans.clear();
        let n = self.rdr.read_until(b'\n', &mut self.buf).map_err(|e| {
            self.eof = true;
            ReadError::new(
                &self.file,
                self.line_no + 1,
                "<line>",
                format!("I/O error: {e}"),
            )
        })?;
        if n == 0 {
            self.eof = true;
            return Ok(false);
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
