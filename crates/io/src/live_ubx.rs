//! A UBX byte stream as a live source (`navfuse live --ubx`, issue 17): a
//! u-blox dead-reckoning receiver sends IMU (ESF), GNSS (NAV-PVT), wheel
//! ticks and dual-antenna heading (NAV-RELPOSNED) on one link, converted by
//! [`crate::ubx_events`] in the source thread and sent as
//! [`Msg::UbxEvent`]s with their arrival time.
//!
//! Specs: `-` (stdin), `tcp:HOST:PORT`, a serial device (configured
//! beforehand, e.g. with `stty`), or a file / FIFO (read to its end). TCP and
//! serial sources are opened again with backoff when lost
//! ([`crate::live_source`]); the converter's state (time anchor, IMU
//! interval, tick counts) carries over a reconnection, the frame parser
//! starts afresh. At the end the source sends its counts
//! ([`Msg::UbxStats`]) and ends both streams ([`Msg::ImuEnd`],
//! [`Msg::GnssEnd`]).

use crate::live_source::{connect, is_char_device, reconnecting, Msg};
use crate::ubx::UbxReader;
use crate::ubx_events::{UbxEvents, UbxEventsConfig};
use crate::RecordStats;
use std::io::{self, Read};
use std::sync::mpsc::SyncSender;
use std::time::Instant;

/// How long after an IMU sample's time a NAV-PVT of an earlier epoch may
/// still arrive on the same link [s]: one navigation epoch at the slowest
/// usual rate (1 Hz) — a receiver sends an epoch's solution within that
/// epoch. Live IMU samples wait at most this much data time for a fix
/// (the live sequencer's GNSS horizon); a fix later than that is counted late.
pub const UBX_PVT_LATENCY_S: f64 = 1.0;

/// Read frames from `r` until its end; false when the receiver is gone.
fn pump(r: impl Read, name: &str, conv: &mut UbxEvents, tx: &SyncSender<Msg>) -> bool {
    let mut rd = UbxReader::new(io::BufReader::with_capacity(1 << 16, r), name);
    let mut gone = false;
    for m in rd.by_ref() {
        match m {
            Ok(m) => conv.push(&m, &mut |e| {
                gone |= tx.send(Msg::UbxEvent(e, Instant::now())).is_err();
            }),
            Err(e) => gone |= tx.send(Msg::ImuNote(e.to_string())).is_err(),
        }
        if gone {
            return false;
        }
    }
    if let Some(e) = rd.last_rejection() {
        let _ = tx.send(Msg::ImuNote(format!("last rejected UBX frame: {e}")));
    }
    tx.send(Msg::UbxStats {
        frames: rd.stats().clone(),
        items: conv.stats().clone(),
    })
    .is_ok()
}

/// Check a `--ubx` spec (anything but an empty string).
pub fn check_ubx_spec(spec: &str) -> Result<(), String> {
    if spec.is_empty() || spec == "tcp:" {
        Err(format!(
            "--ubx {spec:?}: expected -, tcp:HOST:PORT, a serial device or a file"
        ))
    } else {
        Ok(())
    }
}

/// Start the UBX source `spec` (see the module doc).
pub fn spawn_ubx(
    spec: &str,
    cfg: UbxEventsConfig,
    reconnect_for: f64,
    tx: SyncSender<Msg>,
) -> Result<(), String> {
    check_ubx_spec(spec)?;
    let spec = spec.to_string();
    std::thread::spawn(move || {
        let mut conv = UbxEvents::new(cfg);
        let note = Msg::ImuNote;
        if spec == "-" {
            pump(io::stdin().lock(), "<stdin>", &mut conv, &tx);
        } else if let Some(addr) = spec.strip_prefix("tcp:") {
            let serve = |s| pump(s, addr, &mut conv, &tx);
            reconnecting("ubx", reconnect_for, &tx, note, || connect(addr), serve);
        } else if is_char_device(&spec) {
            let open = || std::fs::File::open(&spec);
            let serve = |f| pump(f, &spec, &mut conv, &tx);
            reconnecting("ubx", reconnect_for, &tx, note, open, serve);
        } else {
            match std::fs::File::open(&spec) {
                Ok(f) => {
                    pump(f, &spec, &mut conv, &tx);
                }
                Err(e) => {
                    let _ = tx.send(Msg::ImuNote(format!("ubx {spec}: cannot open: {e}")));
                }
            }
        }
        // What the converter still held back.
        let mut held = Vec::new();
        conv.finish(&mut |e| held.push(e));
        for e in held {
            let _ = tx.send(Msg::UbxEvent(e, Instant::now()));
        }
        let _ = tx.send(Msg::UbxStats {
            frames: RecordStats::default(),
            items: conv.stats().clone(),
        });
        let _ = tx.send(Msg::ImuEnd);
        let _ = tx.send(Msg::GnssEnd);
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use navfuse_core::types::Event;
    use std::io::Write;
    use std::time::Duration;

    /// The same bytes through a file and through TCP with a dropped
    /// connection halfway (at a frame boundary) give the same events.
    #[test]
    fn file_and_tcp_with_a_reconnect_give_the_same_events() {
        let ev = crate::ubx_events_tests::drive_for_tests(3);
        let bytes = crate::ubx_events_tests::to_bytes_for_tests(&ev);
        let collect = |spec: &str| {
            let (tx, rx) = std::sync::mpsc::sync_channel(64);
            let cfg = UbxEventsConfig {
                metres_per_tick: Some(0.02),
                ..Default::default()
            };
            spawn_ubx(spec, cfg, 0.5, tx).unwrap();
            let (mut out, mut ends, mut reconnects, mut items) = (Vec::new(), 0, 0, None);
            while ends < 2 {
                match rx
                    .recv_timeout(Duration::from_secs(20))
                    .expect("source hangs")
                {
                    Msg::UbxEvent(e, _) => out.push(e),
                    Msg::ImuEnd | Msg::GnssEnd => ends += 1,
                    Msg::Reconnect("ubx") => reconnects += 1,
                    Msg::UbxStats { items: i, .. } => items = Some(i),
                    _ => {}
                }
            }
            (out, reconnects, items.unwrap())
        };
        let dir = std::env::temp_dir().join(format!("navfuse_live_ubx_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("log.ubx");
        std::fs::write(&file, &bytes).unwrap();
        let (from_file, _, st_file) = collect(file.to_str().unwrap());
        // Split at a frame boundary near the middle.
        let mut cut = bytes.len() / 2;
        while !(bytes[cut] == 0xB5 && bytes[cut + 1] == 0x62) {
            cut += 1;
        }
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = l.local_addr().unwrap();
        let b2 = bytes.clone();
        let server = std::thread::spawn(move || {
            for part in [&b2[..cut], &b2[cut..]] {
                let (mut s, _) = l.accept().unwrap();
                s.write_all(part).unwrap();
            }
        });
        let (from_tcp, reconnects, st_tcp) = collect(&format!("tcp:{addr}"));
        server.join().unwrap();
        assert_eq!(reconnects, 1);
        assert!(from_file.iter().any(|e| matches!(e, Event::Heading(_))));
        assert_eq!(from_file, from_tcp);
        assert_eq!(st_file, st_tcp);
        assert!(st_file.is_balanced());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
