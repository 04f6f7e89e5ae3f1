//! `navfuse live --estimator cp-att`: CP-ATT (seed 003, the streaming
//! [`CpAttStream`] `Estimator`) on a live carrier-phase CSV stream (the
//! format of [`navfuse_io::carrier_phase`], from stdin, a file / FIFO /
//! serial device or TCP), one attitude solution per epoch written as it is
//! computed. The geometry and filter bounds come from a run configuration's
//! `[cp_att]`, as for `navfuse run --estimator cp-att`.
//!
//! The attitude filter's white-jerk density needs the epoch interval:
//! `navfuse run` takes the file's median interval; a stream takes the
//! interval between its first two epoch times (the first epoch's records are
//! held until the second begins), which is the same on a regular stream, so
//! both give the same solutions (`crates/cli/tests/live_cp_att.rs`). A
//! stream of one epoch uses 1 s, as `run` does.

use crate::config::RunConfig;
use crate::live::Out;
use crate::ToolError;
use navfuse_core::estimators::cp_att_stream::CpAttStream;
use navfuse_core::types::{CarrierPhaseSat, Estimator, Event};
use navfuse_io::carrier_phase::CpCsvReader;
use std::io::BufRead;

/// Most records held before the second epoch arrives (bounded memory: 255
/// satellites × 4 epochs; a stream whose time never advances is an error).
const MAX_HELD: usize = 1020;

/// What a live CP-ATT session did.
#[derive(Clone, Debug, Default)]
pub struct CpLiveSummary {
    pub solutions: u64,
    pub epoch_interval_s: f64,
    /// The reader's and the estimator's counts, as text.
    pub input: String,
    pub estimator: String,
}

/// Run CP-ATT over the records of `src` (named `name` in errors), writing
/// each solution to `out`; `stop()` ends the session early (a signal): the
/// epoch being read then is not completed nor written.
pub fn run_live_cp_att(
    cfg: &RunConfig,
    src: impl BufRead,
    name: &str,
    out: &mut Out,
    stop: &dyn Fn() -> bool,
) -> Result<CpLiveSummary, ToolError> {
    let c = cfg
        .cp_att
        .as_ref()
        .ok_or_else(|| ToolError("[cp_att]: required by CP-ATT (baselines_m)".into()))?;
    let make = |dt: f64| -> Result<CpAttStream, ToolError> {
        let sc = c
            .stream_config(dt)
            .map_err(|m| ToolError(format!("[cp_att] {m}")))?;
        CpAttStream::new(sc).map_err(|e| ToolError(format!("[cp_att] {e}")))
    };
    let mut rdr = CpCsvReader::new(src, name);
    let mut held: Vec<CarrierPhaseSat> = Vec::new();
    let mut est: Option<CpAttStream> = None;
    let mut sum = CpLiveSummary::default();
    let mut stopped = false;
    let mut write = |s: Option<navfuse_core::types::NavSolution>,
                     sum: &mut CpLiveSummary|
     -> Result<(), ToolError> {
        if let Some(s) = s {
            out.write(&s)
                .map_err(|e| ToolError(format!("output: {e}")))?;
            sum.solutions += 1;
        }
        Ok(())
    };
    for r in rdr.by_ref() {
        let r = r.map_err(|e| ToolError(e.to_string()))?;
        if est.is_none() {
            match held.first() {
                Some(h) if r.t > h.t => {
                    sum.epoch_interval_s = r.t - h.t;
                    let mut e = make(sum.epoch_interval_s)?;
                    for h in held.drain(..) {
                        write(e.push(&Event::CarrierPhase(h)), &mut sum)?;
                    }
                    est = Some(e);
                }
                _ => {
                    if held.len() >= MAX_HELD {
                        return Err(ToolError(format!(
                            "{name}: {MAX_HELD} records without a second epoch time"
                        )));
                    }
                    held.push(r);
                    continue;
                }
            }
        }
        let e = est.as_mut().expect("started");
        write(e.push(&Event::CarrierPhase(r)), &mut sum)?;
        if stop() {
            stopped = true;
            break;
        }
    }
    if est.is_none() && !held.is_empty() {
        sum.epoch_interval_s = 1.0;
        let mut e = make(1.0)?;
        for h in held.drain(..) {
            write(e.push(&Event::CarrierPhase(h)), &mut sum)?;
        }
        est = Some(e);
    }
    if let Some(e) = &mut est {
        // At the end of the stream the last epoch is complete; after a
        // stop it may not be (its solution is not written).
        if !stopped {
            write(e.flush(), &mut sum)?;
        }
        let st = e.stats();
        sum.estimator = format!(
            "{} epochs, {} records used; rejected: {} out of order, {} duplicate PRN, {} invalid",
            st.epochs,
            st.records,
            st.rejected_out_of_order,
            st.rejected_duplicate,
            st.rejected_invalid
        );
    }
    sum.input = rdr.stats().to_string();
    Ok(sum)
}

/// The carrier-phase source `spec`: `-` (stdin), `tcp:HOST:PORT` (one
/// connection, read to its end), or a path (file, FIFO or a serial device
/// configured beforehand); with its name for error messages.
pub fn open_source(spec: &str) -> Result<(Box<dyn BufRead + Send>, String), ToolError> {
    if spec == "-" {
        return Ok((
            Box::new(std::io::BufReader::new(std::io::stdin())),
            "<stdin>".into(),
        ));
    }
    if let Some(addr) = spec.strip_prefix("tcp:") {
        let s = std::net::TcpStream::connect(addr)
            .map_err(|e| ToolError(format!("--carrier-phase {spec}: {e}")))?;
        return Ok((Box::new(std::io::BufReader::new(s)), spec.to_string()));
    }
    let f = std::fs::File::open(spec)
        .map_err(|e| ToolError(format!("--carrier-phase {spec}: cannot open: {e}")))?;
    Ok((Box::new(std::io::BufReader::new(f)), spec.to_string()))
}
