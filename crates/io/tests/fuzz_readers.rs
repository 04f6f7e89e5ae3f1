//! Fuzzing every reader on stable Rust: generated and mutated inputs, each
//! run to completion, checking for panics, hangs and unbounded memory.
//!
//! Inputs per reader: mutations of seeds (small synthetic examples of the
//! format, written here, plus — when `navfuse_io::data::data_dir()` exists —
//! windows of 1–40 lines of the real files), format-aware fix-ups so that
//! mutated NMEA lines and UBX frames still pass their checksums and reach the
//! field parsers, token-dictionary generation and raw random bytes; plus a
//! proptest block per format with structured strategies.
//!
//! Case count per reader: `NAVFUSE_FUZZ_CASES` (default 3000, a few seconds
//! in total). The dedicated run: `NAVFUSE_FUZZ_CASES=1000000 cargo test
//! --release -p navfuse-io --test fuzz_readers -- --nocapture --test-threads 1`.
//! Each test prints its case count, input bytes, slowest case and peak
//! per-case heap. Checks per case: no panic (caught; the input is written to
//! `target/fuzz_crashes/` and the test fails), < 2 s, < 64 MiB of heap at
//! its peak (a per-thread counting allocator), and the reader stops within
//! `len + 16` items. A crash found becomes a test in `regressions` below.

use navfuse_io::csv_imu::{CsvImuConfig, CsvImuReader};
use navfuse_io::kfgins::{KfGinsGnssReader, KfGinsImuOptions, KfGinsImuReader, KfGinsNavReader};
use navfuse_io::live::{GpsdAssembler, ImuLineParser};
use navfuse_io::navcsv::NavCsvReader;
use navfuse_io::nmea::{self, NmeaOptions, NmeaReader, NmeaWriter};
use navfuse_io::pos::PosReader;
use navfuse_io::ubx::{self, UbxReader};
use navfuse_io::writers::{CsvWriter, TrajectoryWriter};
use navfuse_io::ReadError;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::time::{Duration, Instant};

// ------------------------------------------------------------ allocator

struct Counting;

thread_local! {
    static CUR: Cell<usize> = const { Cell::new(0) };
    static PEAK: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        let _ = CUR.try_with(|c| {
            let n = c.get() + l.size();
            c.set(n);
            let _ = PEAK.try_with(|p| p.set(p.get().max(n)));
        });
        System.alloc(l)
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        let _ = CUR.try_with(|c| c.set(c.get().saturating_sub(l.size())));
        System.dealloc(p, l)
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        let _ = CUR.try_with(|c| {
            let n = c.get().saturating_sub(l.size()) + new;
            c.set(n);
            let _ = PEAK.try_with(|pk| pk.set(pk.get().max(n)));
        });
        System.realloc(p, l, new)
    }
}

#[global_allocator]
static A: Counting = Counting;

// ------------------------------------------------------------ rng

/// SplitMix64: small, fast, reproducible.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
    fn chance(&mut self, p: f64) -> bool {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 <= p
    }
}

// ------------------------------------------------------------ harness

/// How to run one reader over one input: returns the number of items.
type Run = fn(&[u8]) -> usize;
/// Format-aware repair after mutation (checksums).
type Fixup = fn(&mut Vec<u8>, &mut Rng);

fn drain<T>(it: impl Iterator<Item = Result<T, ReadError>>, cap: usize) -> usize {
    let mut n = 0;
    for r in it {
        n += 1;
        assert!(
            n <= cap,
            "reader yielded more than {cap} items: not terminating"
        );
        if r.is_err() {
            // After an error the readers must end (or keep going): both fine,
            // but they must terminate, which the cap checks.
        }
    }
    n
}

fn cases() -> usize {
    std::env::var("NAVFUSE_FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3000)
}

const TOKENS: &[&[u8]] = &[
    b"nan",
    b"NaN",
    b"inf",
    b"-1e400",
    b"1e308",
    b"0",
    b"-0",
    b"99999999999999999999",
    b"1.0.0",
    b"",
    b" ",
    b"\t",
    b",",
    b",,",
    b"\n",
    b"\r\n",
    b"*",
    b"$",
    b"%",
    b"#",
    b"\xff\xfe",
    b"\xc3\x28",
    b"2025/07/08",
    b"19:34:18.5",
    b"GPST",
    b"UTC",
    b"JST",
    b"latitude(deg)",
    b"$GPGGA",
    b"$GNRMC",
    b"$GPZDA",
    b"$GPGST",
    b"*00",
    b"{",
    b"}",
    b"\"class\":\"TPV\"",
    b"\"time\":\"2025-07-08T19:34:18.250Z\"",
    b"\xb5\x62",
    b"\xb5\x62\x01\x07\x5c\x00",
    b"\xb5\x62\x02\x15\xff\xff",
    b"9",
    b"-",
    b".",
    b"e",
    b"243262.999",
    b"2374",
    b"4005.7976080",
    b"N",
    b"W",
    b"235959.99",
    b"000000",
];

fn mutate(input: &mut Vec<u8>, rng: &mut Rng, seeds: &[Vec<u8>]) {
    let k = 1 + rng.below(6);
    for _ in 0..k {
        let len = input.len();
        match rng.below(11) {
            0 if len > 0 => {
                let i = rng.below(len);
                input[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                input[i] = rng.next() as u8;
            }
            2 => {
                let i = rng.below(len + 1);
                input.insert(i, rng.next() as u8);
            }
            3 if len > 0 => {
                let a = rng.below(len);
                let b = (a + 1 + rng.below(32)).min(len);
                input.drain(a..b);
            }
            4 if len > 0 => {
                let a = rng.below(len);
                let b = (a + 1 + rng.below(64)).min(len);
                let chunk = input[a..b].to_vec();
                let at = rng.below(input.len() + 1);
                input.splice(at..at, chunk);
            }
            5 => {
                let t = TOKENS[rng.below(TOKENS.len())];
                let at = rng.below(len + 1);
                input.splice(at..at, t.iter().copied());
            }
            6 if len > 0 => input.truncate(rng.below(len)),
            7 if !seeds.is_empty() => {
                let s = &seeds[rng.below(seeds.len())];
                if !s.is_empty() {
                    let a = rng.below(s.len());
                    let b = (a + 1 + rng.below(200)).min(s.len());
                    let at = rng.below(len + 1);
                    input.splice(at..at, s[a..b].iter().copied());
                }
            }
            8 if len > 0 => {
                // Replace a run of digits by an extreme number.
                let i = rng.below(len);
                if input[i].is_ascii_digit() {
                    let t: &[u8] =
                        [&b"4294967296"[..], b"-2147483649", b"1e-320", b"256"][rng.below(4)];
                    input.splice(i..i + 1, t.iter().copied());
                }
            }
            9 => {
                // Swap two lines.
                let lines: Vec<&[u8]> = input.split(|&b| b == b'\n').collect();
                if lines.len() > 2 {
                    let (a, b) = (rng.below(lines.len()), rng.below(lines.len()));
                    let mut v: Vec<Vec<u8>> = lines.iter().map(|l| l.to_vec()).collect();
                    v.swap(a, b);
                    *input = v.join(&b'\n');
                }
            }
            _ => {
                let n = rng.below(8);
                for _ in 0..n {
                    let at = rng.below(input.len() + 1);
                    input.insert(at, rng.next() as u8);
                }
            }
        }
    }
    input.truncate(1 << 16);
}

fn generate(rng: &mut Rng) -> Vec<u8> {
    let mut v = Vec::new();
    let n = rng.below(60);
    for _ in 0..n {
        if rng.chance(0.7) {
            v.extend_from_slice(TOKENS[rng.below(TOKENS.len())]);
        } else {
            v.push(rng.next() as u8);
        }
        if rng.chance(0.3) {
            v.push(b' ');
        }
    }
    v
}

struct Report {
    cases: usize,
    bytes: u64,
    items: u64,
    slowest: Duration,
    peak_heap: usize,
}

fn fuzz(name: &str, run: Run, seeds: Vec<Vec<u8>>, fixup: Option<Fixup>) -> Report {
    let n = cases();
    // Seed from the reader name so each reader explores its own sequence.
    let mut rng = Rng(name.bytes().fold(0xC0FFEE, |a: u64, b| {
        a.wrapping_mul(31).wrapping_add(u64::from(b))
    }));
    let mut rep = Report {
        cases: 0,
        bytes: 0,
        items: 0,
        slowest: Duration::ZERO,
        peak_heap: 0,
    };
    let mut input = Vec::with_capacity(1 << 16);
    for case in 0..n {
        input.clear();
        let r = rng.below(100);
        if r < 75 && !seeds.is_empty() {
            input.extend_from_slice(&seeds[rng.below(seeds.len())]);
            mutate(&mut input, &mut rng, &seeds);
            if let Some(f) = fixup {
                if rng.chance(0.6) {
                    f(&mut input, &mut rng);
                }
            }
        } else if r < 92 {
            input = generate(&mut rng);
        } else {
            let len = rng.below(300);
            input.extend((0..len).map(|_| rng.next() as u8));
        }
        let base = CUR.with(|c| c.get());
        PEAK.with(|p| p.set(base));
        let t = Instant::now();
        let res = std::panic::catch_unwind(|| run(&input));
        let dt = t.elapsed();
        let peak = PEAK.with(|p| p.get()).saturating_sub(base);
        match res {
            Ok(items) => rep.items += items as u64,
            Err(e) => {
                let msg = e
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../../target/fuzz_crashes");
                let _ = std::fs::create_dir_all(&dir);
                let p = dir.join(format!("{name}-{case}.bin"));
                let _ = std::fs::write(&p, &input);
                panic!(
                    "{name}: case {case} panicked: {msg}; input saved to {}",
                    p.display()
                );
            }
        }
        assert!(
            dt < Duration::from_secs(2),
            "{name}: case {case} took {dt:?} (hang?) on {} bytes",
            input.len()
        );
        assert!(
            peak < 64 << 20,
            "{name}: case {case} peaked at {peak} bytes of heap on {} bytes of input",
            input.len()
        );
        rep.cases += 1;
        rep.bytes += input.len() as u64;
        rep.slowest = rep.slowest.max(dt);
        rep.peak_heap = rep.peak_heap.max(peak);
    }
    println!(
        "fuzz {name}: {} cases, {} input bytes, {} items, slowest case {:?}, peak heap per case {} KiB, {} seeds",
        rep.cases,
        rep.bytes,
        rep.items,
        rep.slowest,
        rep.peak_heap / 1024,
        seeds.len()
    );
    rep
}

/// Windows of 1–40 lines from the first 512 KiB of a real file, when present.
fn real_seeds(rel: &str, count: usize) -> Vec<Vec<u8>> {
    let p = navfuse_io::data::data_dir().join(rel);
    let Ok(mut b) = std::fs::read(&p) else {
        return Vec::new();
    };
    b.truncate(512 << 10);
    let lines: Vec<&[u8]> = b.split_inclusive(|&c| c == b'\n').collect();
    let mut rng = Rng(count as u64 + lines.len() as u64);
    let mut out = Vec::new();
    // Always the head (headers live there).
    out.push(lines[..lines.len().min(40)].concat());
    for _ in 0..count {
        let a = rng.below(lines.len());
        let e = (a + 1 + rng.below(40)).min(lines.len());
        out.push(lines[a..e].concat());
    }
    out
}

fn with_real(mut synth: Vec<Vec<u8>>, rel: &[&str]) -> Vec<Vec<u8>> {
    for r in rel {
        synth.extend(real_seeds(r, 200));
    }
    synth
}

// ------------------------------------------------------------ readers

fn run_kfgins_imu(b: &[u8]) -> usize {
    let opt = KfGinsImuOptions {
        week: 2374,
        columns: 7,
        nominal_rate_hz: Some(100.0),
    };
    drain(KfGinsImuReader::new(b, "f", opt), b.len() + 16)
}
fn run_kfgins_gnss(b: &[u8]) -> usize {
    drain(KfGinsGnssReader::new(b, "f", 2374), b.len() + 16)
}
fn run_kfgins_nav(b: &[u8]) -> usize {
    drain(KfGinsNavReader::new(b, "f", 2374), b.len() + 16)
}
fn run_pos(b: &[u8]) -> usize {
    drain(PosReader::new(b, "f"), b.len() + 16)
}
fn run_csv_imu(b: &[u8]) -> usize {
    // Alternate the two presets by the input's first byte (both explored).
    let cfg = if b.first().is_some_and(|c| c % 2 == 0) {
        CsvImuConfig::drive_0708()
    } else {
        CsvImuConfig::vn310()
    };
    drain(CsvImuReader::new(b, "f", cfg), b.len() + 16)
}
fn run_nav_csv(b: &[u8]) -> usize {
    drain(NavCsvReader::new(b, "f"), b.len() + 16)
}
fn run_nmea(b: &[u8]) -> usize {
    let mut r = NmeaReader::new(b, "f", NmeaOptions::default());
    let n = drain(r.by_ref(), b.len() + 16);
    assert!(r.stats().is_balanced(), "NMEA accounting: {}", r.stats());
    n
}
fn run_ubx(b: &[u8]) -> usize {
    let mut r = UbxReader::new(b, "f");
    let n = drain(r.by_ref(), b.len() + 16);
    assert!(r.stats().is_balanced(), "UBX accounting: {}", r.stats());
    n
}
/// The UBX reader feeding the UBX → events converter (issue 17): every
/// item accounted, every event finite in time, no panic.
fn run_ubx_events(b: &[u8]) -> usize {
    use navfuse_io::ubx_events::{UbxEvents, UbxEventsConfig};
    let mut c = UbxEvents::new(UbxEventsConfig {
        metres_per_tick: Some(0.02),
        ..Default::default()
    });
    let mut n = 0usize;
    let mut check = |e: navfuse_core::types::Event| {
        assert!(e.t().is_finite(), "event with non-finite time: {e:?}");
        n += 1;
    };
    let mut r = UbxReader::new(b, "f");
    for m in r.by_ref().take(b.len() + 16).flatten() {
        c.push(&m, &mut check);
    }
    c.finish(&mut check);
    assert!(
        c.stats().is_balanced(),
        "UBX events accounting: {}",
        c.stats()
    );
    n
}
fn run_nmea_heading(b: &[u8]) -> usize {
    let mut r = navfuse_io::nmea_heading::NmeaHeadingReader::new(b, "f", 0.01);
    let n = drain(r.by_ref(), b.len() + 16);
    assert!(
        r.stats().is_balanced(),
        "NMEA heading accounting: {}",
        r.stats()
    );
    n
}
fn run_gpsd(b: &[u8]) -> usize {
    let mut a = GpsdAssembler::new();
    let mut n = 0;
    for line in b.split(|&c| c == b'\n') {
        a.push_line(line);
        while a.pop().is_some() {
            n += 1;
        }
    }
    a.flush();
    while a.pop().is_some() {
        n += 1;
    }
    n
}
fn run_imu_lines(b: &[u8]) -> usize {
    let mut p = ImuLineParser::new(2374, Some(100.0));
    let mut out = Vec::new();
    for line in b.split(|&c| c == b'\n') {
        let _ = p.push_line(line, &mut out);
    }
    p.finish();
    assert!(p.stats.is_balanced(), "IMU line accounting: {}", p.stats);
    out.len()
}

fn run_rinex_obs(b: &[u8]) -> usize {
    let text = String::from_utf8_lossy(b);
    let gps = navfuse_io::rinex::parse_obs(&text, "f");
    // The all-systems reader agrees: same result, epochs parallel.
    let all = navfuse_io::rinex::parse_obs_gnss(&text, "f");
    match (&gps, &all) {
        (Ok(f), Ok((f2, g))) => {
            // Compared as text: the reader passes a `NaN` field through,
            // and NaN != NaN.
            assert_eq!(format!("{f:?}"), format!("{f2:?}"));
            assert!(g.epochs.is_empty() || g.epochs.len() == f.epochs.len());
        }
        (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
        _ => panic!("parse_obs and parse_obs_gnss disagree"),
    }
    gps.map_or(0, |f| f.epochs.len())
}
fn run_rinex_nav(b: &[u8]) -> usize {
    let text = String::from_utf8_lossy(b);
    navfuse_io::rinex::parse_nav(&text, "f").map_or(0, |v| v.len())
}

/// RINEX seeds: a synthetic header + epoch, and (with the data) the real
/// header followed by a random window of the body.
fn rinex_seeds(synth: &str, rel: &[&str]) -> Vec<Vec<u8>> {
    let mut out = vec![synth.as_bytes().to_vec()];
    for r in rel {
        let Ok(b) = std::fs::read(navfuse_io::data::data_dir().join(r)) else {
            continue;
        };
        let lines: Vec<&[u8]> = b.split_inclusive(|&c| c == b'\n').collect();
        let Some(h) = lines
            .iter()
            .position(|l| l.windows(13).any(|w| w == b"END OF HEADER"))
        else {
            continue;
        };
        let head = lines[..=h].concat();
        let body = &lines[h + 1..];
        let mut rng = Rng(body.len() as u64);
        for _ in 0..100 {
            let a = rng.below(body.len());
            let e = (a + 1 + rng.below(60)).min(body.len());
            let mut v = head.clone();
            v.extend(body[a..e].concat());
            out.push(v);
        }
    }
    out
}

const RINEX_OBS: &str =
    "     2.10           OBSERVATION DATA    G (GPS)             RINEX VERSION / TYPE
0759                                                        MARKER NAME
 -3976219.5082  3382372.5671  3652512.9849                  APPROX POSITION XYZ
     4    L1    C1    L2    P2                              # / TYPES OF OBSERV
                                                            END OF HEADER
 05  4  2  0  0  0.0000000  0  2G 3R 7
  55923622.160    24767686.375    43647388.2424   24767684.8224
   -691177.898    24361933.475     -537007.1404   24361930.5994
";

/// RINEX 3 observation seed: the reader's mixed GPS/GLONASS/Galileo test file
/// (a header continuation line, an event record).
const RINEX3_OBS: &str = include_str!("../testdata/rinex3_mixed.rnx");

/// RINEX 3 observation seeds: the synthetic file, a Hatanaka header, and
/// `n` generated well-formed files (random systems, codes, flags, satellite
/// counts, values, blanks and LLI) so mutations start near valid input.
fn rinex3_obs_seeds(n: usize) -> Vec<Vec<u8>> {
    const CODES: &[&str] = &[
        "C1C", "L1C", "D1C", "S1C", "C1W", "L1W", "C2W", "L2W", "C2L", "L2L", "C2X", "L2X", "C5Q",
        "L5Q", "C7Q", "L7Q", "C2P", "L2P", "C6I", "X9Z",
    ];
    let mut out = vec![
        RINEX3_OBS.as_bytes().to_vec(),
        format!(
            "{:<60}CRINEX VERS   / TYPE\n{RINEX3_OBS}",
            "1.0                 COMPACT RINEX FORMAT"
        )
        .into_bytes(),
    ];
    let mut rng = Rng(0x52494E3);
    let h = |t: &str, l: &str| format!("{t:<60}{l}\n");
    for _ in 0..n {
        let mut s = h(
            "     3.04           OBSERVATION DATA    M (MIXED)",
            "RINEX VERSION / TYPE",
        );
        let mut systems: Vec<(char, usize)> = Vec::new();
        for sys in "GRECJSI".chars() {
            if sys == 'G' || rng.chance(0.3) {
                let nc = 1 + rng.below(20);
                let codes: Vec<&str> = (0..nc).map(|_| CODES[rng.below(CODES.len())]).collect();
                for (k, chunk) in codes.chunks(13).enumerate() {
                    let head = if k == 0 {
                        format!("{sys}  {nc:3}")
                    } else {
                        " ".repeat(6)
                    };
                    let body: String = chunk.iter().map(|c| format!(" {c}")).collect();
                    s += &h(&format!("{head}{body}"), "SYS / # / OBS TYPES");
                }
                systems.push((sys, nc));
            }
        }
        s += &h("", "END OF HEADER");
        for ep in 0..1 + rng.below(5) {
            let flag = [0, 0, 0, 1, 4, 6][rng.below(6)];
            let nsat = rng.below(7);
            s += &format!(
                "> 2020 06 30 {:02} {:02}{:11.7}  {flag}{nsat:3}\n",
                ep % 24,
                rng.below(60),
                rng.below(60_000_000) as f64 / 1e6
            );
            for _ in 0..nsat {
                if flag == 4 {
                    s += &h("a header line", "COMMENT");
                    continue;
                }
                let (sys, nc) = systems[rng.below(systems.len())];
                s += &format!("{sys}{:02}", 1 + rng.below(40));
                for _ in 0..nc {
                    if rng.chance(0.15) {
                        s += &" ".repeat(16);
                    } else {
                        let v = (rng.next() % 2_000_000_000_000) as f64 / 1000.0 - 1e6;
                        let lli = [" ", "0", "1", "4"][rng.below(4)];
                        s += &format!("{v:14.3}{lli}{}", rng.below(10));
                    }
                }
                s += "\n";
            }
        }
        out.push(s.into_bytes());
    }
    out
}

const RINEX_NAV: &str =
    "     2              NAVIGATION DATA                         RINEX VERSION / TYPE
                                                            END OF HEADER
 1 10  7  1  0  0  0.0-0.136290676892D-03-0.397903932026D-11 0.000000000000D+00
    0.630000000000D+02-0.897500000000D+02 0.468055210664D-08-0.307674634178D+01
   -0.476092100143D-05 0.483528291807D-02 0.545941293240D-05 0.515480139732D+04
    0.345600000000D+06 0.558793544769D-08 0.292603518708D+01-0.931322574615D-07
    0.958292979765D+00 0.226531250000D+03 0.106590540059D+01-0.808748830624D-08
    0.132505519310D-09 0.100000000000D+01 0.158700000000D+04 0.000000000000D+00
    0.200000000000D+01 0.000000000000D+00 0.465661287308D-08 0.630000000000D+02
    0.338418000000D+06 0.400000000000D+01
";

// ------------------------------------------------------------ seeds & fix-ups

fn nmea_seed() -> Vec<Vec<u8>> {
    use navfuse_core::types::{GnssFix, Vec3};
    let mut out = Vec::new();
    let mut buf = Vec::new();
    {
        let mut w = NmeaWriter::new(&mut buf);
        for k in 0..6 {
            let f = GnssFix {
                t: 1_435_700_000.0 + 0.25 * k as f64,
                lat: 0.7,
                lon: -1.8,
                h: 1600.0,
                std_ned: Vec3::new(0.01, 0.02, 0.03),
                quality: 1,
                num_sats: 20,
                v_n: Some(Vec3::new(3.0, -4.0, 0.0)),
                ..Default::default()
            };
            w.write_fix(&f).unwrap();
        }
    }
    out.push(buf);
    let bodies = [
        "GNVTG,054.7,T,034.4,M,005.5,N,010.2,K",
        "GNGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.3,2.1",
        "GPGSV,2,1,08,01,40,083,46,02,17,308,41,12,07,344,39,14,22,228,45",
        "GPZDA,201530.00,04,07,2002,00,00",
        "GPHDT,274.07,T",
        "GNGNS,014035.00,4332.69262,S,17235.48549,E,RR,13,0.9,25.63,11.24,,",
        "GPGGA,201530.00,4807.038,N,01131.000,E,4,08,0.9,545.4,M,46.9,M,,",
    ];
    let mut s = Vec::new();
    for b in bodies {
        s.extend(format!("${b}*{:02X}\r\n", nmea::checksum(b.as_bytes())).bytes());
    }
    out.push(s);
    out
}

/// Recompute the checksum of every `$…*hh` line.
fn nmea_fixup(b: &mut Vec<u8>, _rng: &mut Rng) {
    let mut out = Vec::with_capacity(b.len() + 8);
    for line in b.split_inclusive(|&c| c == b'\n') {
        let body_end = line.iter().rposition(|&c| c == b'*');
        match (line.first(), body_end) {
            (Some(b'$'), Some(star)) => {
                let cs = nmea::checksum(&line[1..star]);
                out.extend_from_slice(&line[..=star]);
                out.extend(format!("{cs:02X}").bytes());
                let rest = &line[star + 1..];
                let skip = rest
                    .iter()
                    .take(2)
                    .take_while(|c| c.is_ascii_hexdigit())
                    .count();
                out.extend_from_slice(&rest[skip..]);
            }
            _ => out.extend_from_slice(line),
        }
    }
    *b = out;
}

fn ubx_seed() -> Vec<Vec<u8>> {
    use ubx::*;
    let pvt = NavPvt {
        year: 2025,
        month: 7,
        day: 8,
        hour: 19,
        min: 34,
        sec: 18,
        valid: 7,
        fix_type: 3,
        flags: 0x81,
        lat_e7: 401_000_000,
        lon_e7: -1_051_000_000,
        height_mm: 1_600_000,
        ..Default::default()
    };
    let rawx = RxmRawx {
        rcv_tow: 243_262.0,
        week: 2374,
        meas: vec![
            RawxMeas {
                pr_mes: 2.1e7,
                cp_mes: 1.1e8,
                trk_stat: 3,
                ..Default::default()
            };
            3
        ],
        ..Default::default()
    };
    let esf_raw = EsfRaw {
        data: vec![
            (
                EsfData {
                    data_type: 14,
                    value: 0xFF_F000
                },
                1000
            );
            4
        ],
    };
    let esf_meas = EsfMeas {
        time_tag: 5,
        flags: 3 << 11,
        id: 0,
        data: vec![
            EsfData {
                data_type: 16,
                value: 10
            };
            3
        ],
        calib_ttag: None,
    };
    let rel = NavRelPosNed {
        version: 1,
        rel_pos_n_cm: 100,
        ..Default::default()
    };
    let msgs = [
        UbxMessage::NavPvt(pvt),
        UbxMessage::RxmRawx(rawx),
        UbxMessage::EsfRaw(esf_raw),
        UbxMessage::EsfMeas(esf_meas),
        UbxMessage::NavRelPosNed(rel),
        UbxMessage::RxmSfrbx(RxmSfrbx {
            gnss_id: 0,
            sv_id: 3,
            num_words: 10,
            version: 2,
            words: [0x22C0_0000; 10],
            ..Default::default()
        }),
    ];
    let mut all = Vec::new();
    let mut out = Vec::new();
    for m in &msgs {
        let f = encode(m);
        all.extend_from_slice(&f);
        out.push(f);
    }
    out.push(all);
    out
}

/// Re-frame: walk sync pairs; where a header's length fits, set the
/// checksum right (and sometimes the length to the bytes that follow).
#[allow(clippy::ptr_arg)] // must match the `Fixup` signature
fn ubx_fixup(b: &mut Vec<u8>, rng: &mut Rng) {
    let mut i = 0;
    while i + 8 <= b.len() {
        if b[i] == 0xB5 && b[i + 1] == 0x62 {
            let mut len = usize::from(u16::from_le_bytes([b[i + 4], b[i + 5]]));
            if i + 8 + len > b.len() || rng.chance(0.2) {
                let avail = b.len() - i - 8;
                len = avail.min(rng.below(avail + 1));
                b[i + 4..i + 6].copy_from_slice(&(len as u16).to_le_bytes());
            }
            let (ca, cb) = ubx::checksum(&b[i + 2..i + 6 + len]);
            b[i + 6 + len] = ca;
            b[i + 7 + len] = cb;
            i += 8 + len;
        } else {
            i += 1;
        }
    }
}

fn gpsd_seed() -> Vec<Vec<u8>> {
    vec![br#"{"class":"VERSION","release":"3.22","rev":"3.22","proto_major":3,"proto_minor":14}
{"class":"TPV","device":"/dev/pts/3","status":3,"mode":3,"time":"2025-07-08T19:34:03.749Z","ept":0.005,"lat":40.096626800,"lon":-105.147448300,"altHAE":1601.4710,"altMSL":1601.4710,"alt":1601.4710,"track":161.5700,"speed":0.003,"geoidSep":0.000,"eph":1.900}
{"class":"GST","device":"/dev/pts/3","time":"2025-07-08T19:34:03.749Z","lat":0.010,"lon":0.010,"alt":0.010}
{"class":"TPV","device":"/dev/pts/3","status":3,"mode":3,"time":"2025-07-08T19:34:03.999Z","lat":40.096626800,"lon":-105.147448300,"altHAE":1601.4750,"epx":1.0,"epy":1.0,"epv":2.0}
{"class":"SKY","satellites":[]}
"#
    .to_vec()]
}

type Seeds = Vec<Vec<u8>>;

fn text_seeds() -> (Seeds, Seeds, Seeds, Seeds) {
    let imu = b"243261.664534 -2.8e-05 -2.5e-04 -3.4e-05 1.2e-04 2.0e-03 -9.8e-02\n243261.674537 -2.0e-05 -1.9e-04 -2.2e-05 -2.3e-04 1.5e-03 -1.0e-01\n243261.684540 5.6e-05 3.3e-04 -1.3e-05 -6.0e-04 1.2e-03 -9.9e-02\n".to_vec();
    let gnss = b"243262.999 40.096626800 -105.147448400 1601.4680 0.0200 0.0200 0.0200\n243263.999 40.096626800 -105.147448300 1601.4730 0.0200 0.0200 0.0200\n".to_vec();
    let gnss13 =
        b"243262.999 40.0966268 -105.1474484 1601.468 0.02 0.02 0.02 0.1 0.2 0.3 0.01 0.01 0.02\n"
            .to_vec();
    let nav = b"2374 243262.999 40.0966268 -105.1474484 1601.468 0.1 0.2 0.0 1.0 2.0 -179.9\n0.000000000 243263.999 40.0966268 -105.1474484 1601.468 0.1 0.2 0.0 nan nan nan\n".to_vec();
    let pos = b"% program   : RTKPOST\n%  GPST                  latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio\n2025/07/08 19:34:18.499   40.096626800 -105.147448300  1601.4740   1  21   0.0099   0.0099   0.0100   0.0000   0.0000   0.0000   0.00    0.0\n2374 243258.749   40.096626800 -105.147448300  1601.4760   2  21   0.0099   0.0099   0.0100   0.0000   0.0000   0.0000   0.00    0.0\n".to_vec();
    (vec![imu], vec![gnss, gnss13], vec![nav], vec![pos])
}

fn nav_csv_seed() -> Vec<Vec<u8>> {
    use navfuse_core::types::NavSolution;
    let mut buf = Vec::new();
    {
        let mut w = CsvWriter::new(&mut buf);
        let mut s = NavSolution::unknown_at(1_435_700_000.0);
        s.lat = 0.7;
        s.lon = -1.8;
        s.h = 1600.0;
        w.write(&s).unwrap();
        s.t += 0.01;
        s.rpy = navfuse_core::types::Vec3::new(0.1, 0.2, 3.0);
        w.write(&s).unwrap();
        w.finish().unwrap();
    }
    vec![buf]
}

fn csv_imu_seed() -> Vec<Vec<u8>> {
    vec![
        b"# gps_week,gps_tow_s,acc_x_g,acc_y_g,acc_z_g,gyro_x_dps,gyro_y_dps,gyro_z_dps\n2374,243261.864,0.01,0.02,1.0,0.1,0.2,0.3\n2374,243261.874,0.01,0.02,1.0,0.1,0.2,0.3\n2374,243261.884,0.02,0.02,1.0,0.1,0.2,0.3\n".to_vec(),
    ]
}

// ------------------------------------------------------------ tests

#[test]
fn fuzz_kfgins_imu() {
    let s = with_real(text_seeds().0, &["drive_0708/kfgins/imu.txt"]);
    fuzz("kfgins_imu", run_kfgins_imu, s, None);
}

#[test]
fn fuzz_kfgins_gnss() {
    let s = with_real(
        text_seeds().1,
        &[
            "drive_0708/kfgins/gnss_full.txt",
            "drive_0708/kfgins/gnss_outage.txt",
        ],
    );
    fuzz("kfgins_gnss", run_kfgins_gnss, s, None);
}

#[test]
fn fuzz_kfgins_nav() {
    let s = with_real(
        text_seeds().2,
        &[
            "drive_0708/kfgins/truth.nav",
            "drive_0708/kfgins/kfgins_result_full_10hz.nav",
        ],
    );
    fuzz("kfgins_nav", run_kfgins_nav, s, None);
}

#[test]
fn fuzz_pos() {
    let s = with_real(text_seeds().3, &["drive_0708/gnss_1934_sf.pos"]);
    fuzz("pos", run_pos, s, None);
}

#[test]
fn fuzz_csv_imu() {
    let s = with_real(
        csv_imu_seed(),
        &["drive_0708/imu_1934_gpst.csv", "static_vn310/vn310-imu.csv"],
    );
    fuzz("csv_imu", run_csv_imu, s, None);
}

#[test]
fn fuzz_nav_csv() {
    fuzz("nav_csv", run_nav_csv, nav_csv_seed(), None);
}

#[test]
fn fuzz_nmea() {
    // Real seed: the drive's .pos written as NMEA, when the data is present.
    let mut s = nmea_seed();
    let pos = navfuse_io::data::data_dir().join("drive_0708/gnss_1934_sf.pos");
    if let Ok((rdr, name)) = navfuse_io::open(&pos) {
        let mut buf = Vec::new();
        {
            let mut w = NmeaWriter::new(&mut buf);
            for f in PosReader::new(rdr, &name).take(400).flatten() {
                w.write_fix(&f).unwrap();
            }
        }
        let lines: Vec<&[u8]> = buf.split_inclusive(|&c| c == b'\n').collect();
        for k in 0..100 {
            let a = (k * 37) % lines.len().max(1);
            s.push(lines[a..(a + 30).min(lines.len())].concat());
        }
    }
    fuzz("nmea", run_nmea, s, Some(nmea_fixup));
}

#[test]
fn fuzz_ubx() {
    fuzz("ubx", run_ubx, ubx_seed(), Some(ubx_fixup));
}

/// Seeds: a simulated receiver stream (ubx_write) with IMU, wheel ticks,
/// NAV-PVT and NAV-RELPOSNED, whole and in windows, plus the plain seeds.
fn ubx_events_seed() -> Vec<Vec<u8>> {
    use navfuse_core::types::*;
    let mut w = navfuse_io::ubx_write::UbxStreamWriter::new(Vec::new(), 0.02);
    let t0 = navfuse_io::time::gps_seconds(2374, 243_300.0);
    for k in 1..=300 {
        let t = t0 + k as f64 * 0.01;
        let ev = [
            Event::Imu(ImuSample {
                t,
                dt: 0.01,
                dtheta_b: Vec3::new(1e-4, 0.0, 1e-3),
                dvel_b: Vec3::new(0.0, 0.0, -0.098),
            }),
            Event::Odometer(OdometerSample {
                t,
                dt: 0.01,
                speed_mps: 3.0,
                std_mps: 0.0,
                wheel: 0,
            }),
            Event::Gnss(GnssFix {
                t,
                lat: 0.7,
                lon: 0.2,
                h: 10.0,
                std_ned: Vec3::repeat(1.0),
                quality: 1,
                ..Default::default()
            }),
            Event::Heading(HeadingFix {
                t,
                heading_rad: 1.0,
                pitch_rad: 0.0,
                std_heading_rad: 0.01,
                std_pitch_rad: 0.02,
                baseline_m: 1.0,
                source: HeadingSource::DualAntenna,
            }),
        ];
        for (i, e) in ev.iter().enumerate() {
            if i == 0 || k % (10 * i) == 0 {
                w.write(e).unwrap();
            }
        }
    }
    let all = w.into_inner();
    let mut s = ubx_seed();
    for k in 0..40 {
        let a = (k * 997) % all.len();
        s.push(all[a..(a + 2000).min(all.len())].to_vec());
    }
    s.push(all);
    s
}

#[test]
fn fuzz_nmea_heading() {
    let mut s = nmea_seed();
    let body = |b: &str| format!("${b}*{:02X}\r\n", nmea::checksum(b.as_bytes()));
    let mut burst = String::new();
    for k in 0..20 {
        burst += &body(&format!(
            "GPRMC,1200{k:02}.00,A,4000.0000,N,10500.0000,W,0.0,0.0,010125,,,A"
        ));
        burst += &body(&format!("GPHDT,{}.5,T", k * 17 % 360));
        burst += &body(&format!(
            "GNTHS,{}.25,{}",
            k * 7 % 360,
            ["A", "E", "V", "M", "S"][k % 5]
        ));
    }
    s.push(burst.into_bytes());
    fuzz("nmea_heading", run_nmea_heading, s, Some(nmea_fixup));
}

#[test]
fn fuzz_ubx_events() {
    fuzz(
        "ubx_events",
        run_ubx_events,
        ubx_events_seed(),
        Some(ubx_fixup),
    );
}

#[test]
fn fuzz_gpsd_json() {
    fuzz("gpsd_json", run_gpsd, gpsd_seed(), None);
}

#[test]
fn fuzz_live_imu_lines() {
    let s = with_real(text_seeds().0, &["drive_0708/kfgins/imu.txt"]);
    fuzz("live_imu_lines", run_imu_lines, s, None);
}

#[test]
fn fuzz_rinex_obs() {
    let s = rinex_seeds(
        RINEX_OBS,
        &["gnss/rinex/07590920.05o", "gnss/rinex/30400920.05o"],
    );
    fuzz("rinex_obs", run_rinex_obs, s, None);
}

#[test]
fn fuzz_rinex3_obs() {
    // Plus the RINEX 2 seeds: a version line mutated to 3.xx reaches the
    // RINEX 3 path with RINEX 2 records.
    let mut s = rinex3_obs_seeds(200);
    // The generated seeds are valid files (so mutations start near valid input).
    for (k, b) in s[2..].iter().enumerate() {
        let t = std::str::from_utf8(b).unwrap();
        if let Err(e) = navfuse_io::rinex::parse_obs(t, "seed") {
            panic!("generated seed {k} does not parse: {e}\n{t}");
        }
    }
    assert!(navfuse_io::rinex::parse_obs(std::str::from_utf8(&s[1]).unwrap(), "crx").is_err());
    s.extend(rinex_seeds(RINEX_OBS, &["gnss/rinex/07590920.05o"]));
    fuzz("rinex3_obs", run_rinex_obs, s, None);
}

#[test]
fn fuzz_rinex_nav() {
    let s = rinex_seeds(
        RINEX_NAV,
        &["gnss/rinex/brdc1820.10n", "gnss/rinex/07590920.05n"],
    );
    fuzz("rinex_nav", run_rinex_nav, s, None);
}

fn run_rinex3_nav(b: &[u8]) -> usize {
    let text = String::from_utf8_lossy(b);
    navfuse_io::rinex_nav3::parse_nav_gnss(&text, "f").map_or(0, |n| {
        for e in &n.ephs {
            // Whatever parses evaluates without a panic.
            let _ = navfuse_core::gnss::orbit_gnss::position_ecef(&e.orbit, e.kind, e.orbit.t_oe);
        }
        n.ephs.len()
    })
}

/// RINEX 3 multi-GNSS navigation (Galileo, BeiDou GEO, a skipped GLONASS record).
const RINEX3_NAV: &str =
    "     3.04           N: GNSS NAV DATA    M: MIXED            RINEX VERSION / TYPE
                                                            END OF HEADER
E11 2019 01 01 00 10 00-6.408181018196E-04-7.261957228184E-12 0.000000000000E+00
     1.200000000000E+01-3.190625000000E+01 2.826546881327E-09 1.060935766467E+00
    -1.504272222519E-06 1.573478034697E-04 5.958601832390E-06 5.440611837387E+03
     1.746000000000E+05 4.656612873077E-09-1.196298196014E+00 2.793967723846E-08
     9.847683962432E-01 2.245625000000E+02 3.136049563113E-01-5.625586602126E-09
    -2.007226171524E-10 5.170000000000E+02 2.034000000000E+03 0.000000000000E+00
     3.120000000000E+00 0.000000000000E+00-1.629814505577E-09-1.862645149231E-09
     1.753940000000E+05
R05 2019 01 01 00 15 00 7.406435906887E-05 0.000000000000E+00 1.746000000000E+05
     1.0E+04 0.0E+00 0.0E+00 0.0E+00
     1.0E+04 0.0E+00 0.0E+00 1.0E+00
     1.0E+04 0.0E+00 0.0E+00 0.0E+00
C01 2019 01 01 00 00 00 5.287066334859E-04 4.010480264303E-11 0.000000000000E+00
     1.000000000000E+00 6.398437500000E+00 4.121242095640E-10-2.733027462568E+00
     2.021389082074E-07 4.872011882253E-04 2.132053486000E-05 6.493390665054E+03
     1.728000000000E+05 1.862645149231E-08 2.825587713009E+00-4.470348358154E-08
     9.072369124127E-02-6.549687500000E+02-3.010917932913E+00 2.878691633015E-10
    -1.046472733001E-09 0.000000000000E+00 6.780000000000E+02 0.000000000000E+00
     2.000000000000E+00 0.000000000000E+00-5.800000000000E-09-1.020000000000E-08
     1.728000000000E+05 1.000000000000E+00
";

#[test]
fn fuzz_rinex3_nav() {
    assert_eq!(run_rinex3_nav(RINEX3_NAV.as_bytes()), 2, "the seed parses");
    fuzz(
        "rinex3_nav",
        run_rinex3_nav,
        vec![RINEX3_NAV.as_bytes().to_vec()],
        None,
    );
}

/// Carrier-phase CSV (CP-ATT input, issue 17): every record finite, the
/// accounting balanced after a complete read.
fn run_carrier_phase(b: &[u8]) -> usize {
    let mut r = navfuse_io::carrier_phase::CpCsvReader::new(b, "f");
    let mut n = 0;
    let mut ok = true;
    for x in r.by_ref().take(b.len() + 16) {
        n += 1;
        match x {
            Ok(c) => assert!(
                c.t.is_finite() && c.sigma_m > 0.0 && (1..=4).contains(&c.n_baselines),
                "{c:?}"
            ),
            Err(_) => ok = false,
        }
    }
    if ok {
        assert!(r.stats().is_balanced(), "CP CSV accounting: {}", r.stats());
    }
    n
}

fn carrier_phase_seed() -> Vec<Vec<u8>> {
    let mut s = String::from("# cp\n");
    s += &navfuse_io::carrier_phase::header(3);
    s.push('\n');
    for e in 0..20 {
        for (k, prn) in [12, 5, 29, 17].iter().enumerate() {
            s += &format!(
                "{},{prn},{},0.6,0.0,0.8,0.002,{},{},{}\n",
                1_235_000_000.0 + e as f64,
                u8::from(k == 3),
                0.713 + e as f64 * 1e-3,
                -1834.2 + k as f64,
                93.44
            );
        }
    }
    vec![
        s.into_bytes(),
        b"t_gps_s,prn,last_in_epoch,los_e,los_n,los_u,sigma_m,sd1_m\n1,1,1,1,0,0,0.01,0.5\n"
            .to_vec(),
    ]
}

#[test]
fn fuzz_carrier_phase() {
    fuzz(
        "carrier_phase",
        run_carrier_phase,
        carrier_phase_seed(),
        None,
    );
}

/// Odometer CSV by column map (issue 17), the map chosen by the first byte
/// (speed of two wheels with a reverse column, cumulative distance by
/// index, increments): finite samples within the speed bound, accounting
/// balanced after a complete read.
fn run_odometer_csv(b: &[u8]) -> usize {
    use navfuse_io::csv_imu::Col;
    use navfuse_io::odometer_csv::{OdoCsvConfig, OdoCsvReader, OdoQuantity, MAX_SPEED_MPS};
    let name = |s: &str| Col::Name(s.into());
    let mut cfg = OdoCsvConfig::speed(name("t"), name("v"));
    match b.first().map_or(0, |c| c % 3) {
        0 => {
            cfg.values = vec![name("rl"), name("rr")];
            cfg.reverse = Some(name("gear_r"));
            cfg.unit = 1.0 / 3.6;
        }
        1 => {
            cfg = OdoCsvConfig::speed(Col::Index(0), Col::Index(2));
            cfg.quantity = OdoQuantity::Distance;
        }
        _ => cfg.quantity = OdoQuantity::Increment,
    }
    let mut r = OdoCsvReader::new(b, "f", cfg);
    let (mut n, mut ok) = (0, true);
    for x in r.by_ref().take(b.len() + 16) {
        n += 1;
        match x {
            Ok(o) => assert!(
                o.t.is_finite() && o.dt >= 0.0 && o.speed_mps.abs() <= MAX_SPEED_MPS,
                "{o:?}"
            ),
            Err(_) => ok = false,
        }
    }
    if ok {
        assert!(
            r.stats().is_balanced(),
            "odometer CSV accounting: {}",
            r.stats()
        );
    }
    n
}

fn odometer_csv_seed() -> Vec<Vec<u8>> {
    let mut a = String::from("# wheels\nt,rl,rr,gear_r\n");
    let mut b = String::from("t,x,odo_m\n");
    let mut c = String::from("t,v\n");
    for k in 0..50 {
        let t = 1_235_000_000.0 + k as f64 * 0.1;
        a += &format!(
            "{t},{},{},{}\n",
            30.0 + k as f64 * 0.1,
            30.2,
            u8::from(k > 40)
        );
        b += &format!("{t},0,{}\n", 100.0 + k as f64 * 0.83);
        c += &format!("{t},{}\n", 0.8 - (k % 7) as f64 * 0.2);
    }
    // First bytes (a blank line: skipped) chosen so each map sees its own
    // format: '\t' % 3 = 0, '\n' % 3 = 1, 't' % 3 = 2.
    vec![
        format!("\t\n{a}").into_bytes(),
        format!("\n{b}").into_bytes(),
        c.into_bytes(),
    ]
}

#[test]
fn fuzz_odometer_csv() {
    fuzz("odometer_csv", run_odometer_csv, odometer_csv_seed(), None);
}

/// UBX raw GNSS (issue 14): RXM-RAWX and RXM-SFRBX through
/// `read_ubx_gnss`, whose decoders for Galileo I/NAV and BeiDou D1/D2 are
/// reached through the SFRBX fix-up below. Checks: no panic, GPS and
/// multi-GNSS epochs parallel, every ephemeris decoded (GLONASS too)
/// evaluates without a panic, of the system it came from.
fn run_ubx_gnss(b: &[u8]) -> usize {
    let Ok(u) = navfuse_io::ubx_gnss::read_ubx_gnss(b, "f") else {
        return 0;
    };
    assert_eq!(u.obs.epochs.len(), u.gnss.epochs.len());
    for e in &u.other {
        assert!(matches!(e.sys, 'E' | 'C'), "{e:?}");
        let _ = navfuse_core::gnss::orbit_gnss::position_ecef(&e.orbit, e.kind, e.orbit.t_oe);
        let _ = navfuse_core::gnss::orbit_gnss::clock_offset(&e.orbit, e.kind, e.orbit.t_oe);
    }
    for e in &u.glonass {
        let _ = e.position_ecef(e.t_b + 900.0);
    }
    let n = u.obs.epochs.len() + u.nav.orbits.len() + u.other.len() + u.glonass.len();
    assert_eq!(u.report.ephemerides_glonass, u.glonass.len() as u64);
    assert_eq!(
        u.report.ephemerides_galileo + u.report.ephemerides_beidou,
        u.other.len() as u64
    );
    n
}

/// Seeds: RAWX epochs (GPS L1 C/A and L2 CL, Galileo E1 and E5b, BeiDou
/// B1I and B2I measurements) and the SFRBX of the RINEX 3 seed's Galileo (I/NAV, E1-B order) or BeiDou
/// (C01 as D2 pages, the same elements as C11 in D1 subframes) records,
/// written by `write_ubx_multi`; each system alone and together.
fn ubx_gnss_seeds(systems: &[char]) -> Vec<Vec<u8>> {
    use navfuse_io::rinex::{GnssObs, NavData, ObsEpoch, ObsFile, ObsValue};
    let nav = navfuse_io::rinex_nav3::parse_nav_gnss(RINEX3_NAV, "seed").unwrap();
    let mut other: Vec<_> = nav
        .ephs
        .iter()
        .filter(|e| systems.contains(&e.sys))
        .copied()
        .collect();
    if let Some(c) = other.iter().find(|e| e.sys == 'C').copied() {
        let mut meo = c;
        meo.orbit.prn = 11;
        meo.kind = navfuse_core::gnss::orbit_gnss::OrbitKind::BeiDou;
        other.push(meo);
    }
    let glonass = if systems.contains(&'R') {
        navfuse_io::rinex_glonass::parse_nav_glonass(GLO_NAV, "seed").unwrap()
    } else {
        Vec::new()
    };
    let t0 = other
        .first()
        .map(|e| e.orbit.t_oe)
        .or(glonass.first().map(|e| e.t_b))
        .unwrap();
    let v = |x: f64| Some(ObsValue { value: x, lli: 0 });
    let obs = ObsFile {
        types: ["C1", "L1", "D1", "S1", "C2", "L2"]
            .map(String::from)
            .to_vec(),
        epochs: (0..3)
            .map(|k| ObsEpoch {
                t: t0 + k as f64,
                flag: 0,
                sats: vec![(
                    5,
                    vec![
                        v(2.1e7),
                        v(1.1e8),
                        v(-1200.0),
                        v(44.0),
                        v(2.1e7 + 3.0),
                        v(8.6e7),
                    ],
                )],
            })
            .collect(),
        ..ObsFile::default()
    };
    let gnss = GnssObs {
        sys_codes: vec![
            (
                'E',
                ["C1C", "L1C", "D1C", "S1C", "C7Q", "L7Q"]
                    .map(String::from)
                    .to_vec(),
            ),
            (
                'C',
                ["C2I", "L2I", "D2I", "S2I", "C7I", "L7I"]
                    .map(String::from)
                    .to_vec(),
            ),
        ],
        // Both frequencies of each system (RTK input, sigIds 3, 6, 2/3).
        epochs: (0..3)
            .map(|_| {
                vec![
                    (
                        'E',
                        11,
                        vec![v(2.4e7), v(1.2e8), v(300.0), v(41.0), v(2.4e7), v(9.6e7)],
                    ),
                    (
                        'C',
                        1,
                        vec![v(3.7e7), v(1.9e8), v(5.0), v(38.0), v(3.7e7), v(1.5e8)],
                    ),
                    (
                        'C',
                        11,
                        vec![v(2.2e7), v(1.15e8), v(-900.0), v(40.0), v(2.2e7), v(9.0e7)],
                    ),
                ]
            })
            .collect(),
    };
    let whole =
        navfuse_io::ubx_gnss::write_ubx_multi(&obs, &gnss, &NavData::default(), &other, &glonass)
            .unwrap();
    assert!(
        run_ubx_gnss(&whole) >= 3 + other.len() + glonass.len(),
        "the seed decodes its ephemerides"
    );
    // The whole stream, and its frames one by one.
    let mut out = vec![whole.clone()];
    let mut i = 0;
    while i + 8 <= whole.len() {
        let len = usize::from(u16::from_le_bytes([whole[i + 4], whole[i + 5]]));
        out.push(whole[i..i + 8 + len].to_vec());
        i += 8 + len;
    }
    out
}

/// [`ubx_fixup`] after repairing mutated SFRBX content so that it reaches
/// the field decoders: a Galileo page pair (gnssId 2, 8 words) gets its
/// even/odd bits, page type and CRC-24Q rebuilt around its data bits, a
/// BeiDou subframe (gnssId 3, 10 words) its preamble.
#[allow(clippy::ptr_arg)] // must match the `Fixup` signature
fn sfrbx_fixup(b: &mut Vec<u8>, rng: &mut Rng) {
    let mut i = 0;
    while i + 8 <= b.len() {
        let len = usize::from(u16::from_le_bytes([b[i + 4], b[i + 5]]));
        if b[i] == 0xB5 && b[i + 1] == 0x62 && b[i + 2] == 0x02 && b[i + 3] == 0x13 {
            let p = i + 6;
            let n = usize::from(b.get(p + 4).copied().unwrap_or(0));
            if p + 8 + 4 * n <= b.len() {
                let word = |k: usize| {
                    let o = p + 8 + 4 * k;
                    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
                };
                let words: Vec<u32> = (0..n).map(word).collect();
                let fixed: Option<Vec<u32>> = match (b[p], n) {
                    (2, 8) if rng.chance(0.8) => {
                        let j = |w: &[u32]| w.iter().fold(0u128, |a, &x| (a << 32) | u128::from(x));
                        let (even, odd) = (j(&words[..4]), j(&words[4..]));
                        let data =
                            (((even >> 14) & ((1u128 << 112) - 1)) << 16) | ((odd >> 110) & 0xFFFF);
                        Some(navfuse_io::galileo_inav::encode_pages(data).to_vec())
                    }
                    (6, 4) if rng.chance(0.8) => {
                        let mut w = words.clone();
                        let m = (w[0] >> 27) & 0xF;
                        w[0] = (w[0] & !(0xF << 27)) | ((m % 4 + 1) << 27);
                        Some(w)
                    }
                    (3, 10) if rng.chance(0.8) => {
                        let mut w = words.clone();
                        w[0] = (w[0] & !(0x7FF << 19)) | (0x712 << 19);
                        Some(w)
                    }
                    _ => None,
                };
                if let Some(f) = fixed {
                    for (k, x) in f.iter().enumerate() {
                        let o = p + 8 + 4 * k;
                        b[o..o + 4].copy_from_slice(&x.to_le_bytes());
                    }
                }
            }
        }
        let sync = b[i] == 0xB5 && b[i + 1] == 0x62;
        i += if sync { 8 + len } else { 1 };
    }
    ubx_fixup(b, rng);
}

#[test]
fn fuzz_ubx_sfrbx_galileo() {
    fuzz(
        "ubx_sfrbx_galileo",
        run_ubx_gnss,
        ubx_gnss_seeds(&['E']),
        Some(sfrbx_fixup),
    );
}

/// RINEX 2 `.g` and RINEX 3 GLONASS records (`rinex_glonass`): whatever
/// parses integrates over ±15 min without a panic.
fn run_rinex_glonass(b: &[u8]) -> usize {
    let text = String::from_utf8_lossy(b);
    navfuse_io::rinex_glonass::parse_nav_glonass(&text, "f").map_or(0, |v| {
        for e in &v {
            let _ = e.position_ecef(e.t_b + 900.0);
            let _ = e.position_ecef(e.t_b - 900.0);
        }
        v.len()
    })
}

/// A RINEX 2.11 GLONASS navigation file (D exponents).
const GLO_NAV2: &str =
    "     2.11           G: GLONASS NAV DATA                     RINEX VERSION / TYPE
                                                            END OF HEADER
 7 12  9  7  0 15  0.0-1.199999824166D-04 9.094947017729D-13 0.000000000000D+00
    7.003008789062D+03 7.835416793823D-01 0.000000000000D+00 0.000000000000D+00
   -1.220662695312D+04 2.804252624512D+00 1.862645149231D-09 1.000000000000D+00
    2.128076562500D+04 1.352515220642D+00-5.587935447693D-09 3.000000000000D+00
";

#[test]
fn fuzz_rinex_glonass_nav() {
    assert_eq!(
        run_rinex_glonass(GLO_NAV.as_bytes()),
        1,
        "the RINEX 3 seed parses"
    );
    assert_eq!(
        run_rinex_glonass(GLO_NAV2.as_bytes()),
        1,
        "the RINEX 2 seed parses"
    );
    fuzz(
        "rinex_glonass_nav",
        run_rinex_glonass,
        vec![GLO_NAV.as_bytes().to_vec(), GLO_NAV2.as_bytes().to_vec()],
        None,
    );
}

/// A GLONASS RINEX 3 record on the broadcast grid (t_b 03:15 Moscow time).
const GLO_NAV: &str =
    "     3.04           N: GNSS NAV DATA    R: GLONASS          RINEX VERSION / TYPE
                                                            END OF HEADER
R07 2012 09 07 00 15 00-1.199999824166E-04 9.094947017729E-13 0.000000000000E+00
     7.003008789062E+03 7.835416793823E-01 0.000000000000E+00 0.000000000000E+00
    -1.220662695312E+04 2.804252624512E+00 1.862645149231E-09 1.000000000000E+00
     2.128076562500E+04 1.352515220642E+00-5.587935447693E-09 3.000000000000E+00
";

#[test]
fn fuzz_ubx_sfrbx_glonass() {
    fuzz(
        "ubx_sfrbx_glonass",
        run_ubx_gnss,
        ubx_gnss_seeds(&['R']),
        Some(sfrbx_fixup),
    );
}

#[test]
fn fuzz_ubx_sfrbx_beidou() {
    fuzz(
        "ubx_sfrbx_beidou",
        run_ubx_gnss,
        ubx_gnss_seeds(&['C']),
        Some(sfrbx_fixup),
    );
}

mod structured {
    //! proptest strategies that build well-formed frames/sentences around
    //! arbitrary content, so the field parsers behind the checksums are hit.
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

        #[test]
        fn ubx_frames_with_arbitrary_payloads(
            frames in proptest::collection::vec(
                (prop_oneof![Just((1u8, 7u8)), Just((2, 0x15)), Just((0x10, 3)), Just((0x10, 2)),
                             Just((1, 0x3C)), any::<(u8, u8)>()],
                 proptest::collection::vec(any::<u8>(), 0..600)), 0..6),
            junk in proptest::collection::vec(any::<u8>(), 0..20)) {
            let mut b = junk;
            for ((c, i), p) in &frames {
                b.extend(ubx::frame(*c, *i, p));
            }
            run_ubx(&b);
        }

        #[test]
        fn nmea_sentences_with_arbitrary_fields(
            lines in proptest::collection::vec(
                (prop_oneof![Just("GPGGA"), Just("GNRMC"), Just("GPVTG"), Just("GPGST"), Just("GNGSA"),
                             Just("GPGSV"), Just("GPZDA"), Just("GPHDT"), Just("GNGNS"), Just("XXGGA")],
                 proptest::collection::vec("[0-9NSEWAV.,+-]{0,12}", 0..20)), 0..12)) {
            let mut b = Vec::new();
            for (addr, f) in &lines {
                let body = format!("{addr},{}", f.join(","));
                b.extend(format!("${body}*{:02X}\r\n", nmea::checksum(body.as_bytes())).bytes());
            }
            run_nmea(&b);
        }

        #[test]
        fn arbitrary_bytes_every_reader(b in proptest::collection::vec(any::<u8>(), 0..2000)) {
            for run in [run_kfgins_imu, run_kfgins_gnss, run_kfgins_nav, run_pos, run_csv_imu,
                        run_nav_csv, run_nmea, run_ubx, run_gpsd, run_imu_lines, run_rinex_obs,
                        run_rinex_nav, run_ubx_gnss] {
                run(&b);
            }
        }
    }
}

mod regressions {
    //! Inputs that once crashed a reader (found by the fuzzers above).
    use super::*;

    #[test]
    fn ubx_length_that_reaches_past_the_buffer_is_a_truncation() {
        let mut b = ubx::frame(1, 7, &[0; 92]);
        b[4] = 0xFF;
        b[5] = 0x1F; // 8191 bytes claimed, 92 present
        assert_eq!(run_ubx(&b), 0);
    }
}

mod regressions_found {
    //! Crashes the fuzzers found, kept as tests (inputs in `fuzz_regressions/`).
    use super::*;

    /// An NMEA epoch rejected at closing (time not increasing) was counted
    /// twice (used + rejected): the accounting no longer balanced.
    #[test]
    fn nmea_rejected_epoch_is_counted_once() {
        let b = include_bytes!("fuzz_regressions/nmea_accounting.nmea");
        let mut r = NmeaReader::new(&b[..], "f", NmeaOptions::default());
        for x in r.by_ref() {
            let _ = x;
        }
        assert!(r.stats().is_balanced(), "{}", r.stats());
    }
}

mod regressions_rinex {
    //! Found by `fuzz_rinex_nav`: a multi-byte character across column 60 made
    //! the RINEX nav header scan slice inside a character (panic).
    use super::*;

    #[test]
    fn rinex_nav_label_column_inside_a_character() {
        let b = include_bytes!("fuzz_regressions/rinex_nav_char_boundary.txt");
        run_rinex_nav(b);
        // The same through the obs parser, and a minimal hand-made case.
        run_rinex_obs(b);
        let line = format!("{}é RINEX VERSION / TYPE\n", " ".repeat(59));
        run_rinex_nav(line.as_bytes());
    }
}

mod regressions_rinex_obs {
    //! Found by `fuzz_rinex_obs` (case 379645 of the 1,000,000 run): an epoch
    //! line whose satellite count read as `inf` sized a Vec (capacity
    //! overflow panic); counts are now checked to be 0..999.
    use super::*;

    #[test]
    fn rinex_obs_satellite_count_that_is_not_a_count() {
        let b = include_bytes!("fuzz_regressions/rinex_obs_capacity.txt");
        run_rinex_obs(b);
        let mut hand = RINEX_OBS.replace(" 0  2G 3R 7", " 0inf 3R 7");
        run_rinex_obs(hand.as_bytes());
        hand = RINEX_OBS.replace(" 0  2G 3R 7", " 01e9 3R 7");
        run_rinex_obs(hand.as_bytes());
    }
}
