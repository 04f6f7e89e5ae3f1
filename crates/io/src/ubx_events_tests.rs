//! Tests of [`crate::ubx_events`] through [`crate::ubx_write`]: events →
//! UBX bytes → reader → events, with their counts, values and times.

use crate::time::gps_seconds;
use crate::ubx::{encode, EsfData, EsfRaw, NavRelPosNed, UbxMessage, UbxReader};
use crate::ubx_events::*;
use crate::ubx_write::UbxStreamWriter;
use navfuse_core::types::{
    Event, GnssFix, HeadingFix, HeadingSource, ImuSample, OdometerSample, Vec3,
};

const M_PER_TICK: f64 = 0.02;

/// 100 Hz IMU, 10 Hz odometer, 1 Hz GNSS + heading for `secs` seconds.
fn drive(secs: usize) -> Vec<Event> {
    let t0 = gps_seconds(2374, 243_300.0);
    let mut ev = Vec::new();
    for k in 1..=secs * 100 {
        let t = t0 + k as f64 * 0.01;
        let w = Vec3::new(0.001, -0.002, 0.1);
        let f = Vec3::new(0.5, 0.01, -9.8);
        ev.push(Event::Imu(ImuSample {
            t,
            dt: 0.01,
            dtheta_b: w * 0.01,
            dvel_b: f * 0.01,
        }));
        if k % 10 == 0 {
            ev.push(Event::Odometer(OdometerSample {
                t,
                dt: 0.1,
                speed_mps: 5.0,
                std_mps: 0.0,
                wheel: 0,
            }));
        }
        if k % 100 == 50 {
            ev.push(Event::Gnss(GnssFix {
                t,
                lat: 0.7 + 1e-6 * k as f64,
                lon: -1.8,
                h: 100.0 + k as f64 * 1e-3,
                std_ned: Vec3::new(0.5, 0.5, 1.0),
                v_n: Some(Vec3::new(5.0, 0.1, 0.0)),
                std_v_n: Some(Vec3::repeat(0.05)),
                quality: 5,
                num_sats: 12,
            }));
            ev.push(Event::Heading(HeadingFix {
                t,
                heading_rad: -2.5 + 1e-3 * k as f64,
                pitch_rad: 0.01,
                std_heading_rad: 0.005,
                std_pitch_rad: 0.01,
                baseline_m: 1.2,
                source: HeadingSource::DualAntenna,
            }));
        }
    }
    ev
}

fn to_bytes(ev: &[Event], tag0: Option<u32>) -> Vec<u8> {
    let mut w = UbxStreamWriter::new(Vec::new(), M_PER_TICK);
    if let Some(t) = tag0 {
        w.tag0 = t;
    }
    for e in ev {
        w.write(e).unwrap();
    }
    w.into_inner()
}

fn convert(bytes: &[u8], cfg: UbxEventsConfig) -> (Vec<Event>, UbxEvents) {
    let mut c = UbxEvents::new(cfg);
    let mut out = Vec::new();
    let mut r = UbxReader::new(bytes, "t.ubx");
    for m in r.by_ref() {
        c.push(&m.unwrap(), &mut |e| out.push(e));
    }
    c.finish(&mut |e| out.push(e));
    assert!(r.stats().is_balanced());
    assert_eq!(r.stats().rejected_total(), 0);
    (out, c)
}

fn cfg() -> UbxEventsConfig {
    UbxEventsConfig {
        metres_per_tick: Some(M_PER_TICK),
        ..Default::default()
    }
}

#[test]
fn round_trip_counts_values_and_times_across_the_tag_wrap() {
    let ev = drive(5);
    // The sensor time tag wraps 1.5 s into the drive.
    let bytes = to_bytes(&ev, Some(u32::MAX - 1500));
    let (got, c) = convert(&bytes, cfg());
    let pick =
        |v: &[Event], f: fn(&Event) -> bool| v.iter().filter(|e| f(e)).cloned().collect::<Vec<_>>();
    let (imu_in, imu) = (
        pick(&ev, |e| matches!(e, Event::Imu(_))),
        pick(&got, |e| matches!(e, Event::Imu(_))),
    );
    assert_eq!(imu.len(), imu_in.len());
    for (a, b) in imu_in.iter().zip(&imu) {
        let (Event::Imu(a), Event::Imu(b)) = (a, b) else {
            unreachable!()
        };
        assert!((a.t - b.t).abs() < 1e-6, "{} vs {}", a.t, b.t);
        assert!((a.dt - b.dt).abs() < 1e-6);
        // Quantisation: 2⁻¹² °/s and 2⁻¹⁰ m/s² per LSB, over 10 ms.
        assert!((a.dtheta_b - b.dtheta_b).amax() < 1e-7);
        assert!((a.dvel_b - b.dvel_b).amax() < 1e-5);
    }
    let gnss = pick(&got, |e| matches!(e, Event::Gnss(_)));
    let gnss_in = pick(&ev, |e| matches!(e, Event::Gnss(_)));
    assert_eq!(gnss.len(), gnss_in.len());
    for (a, b) in gnss_in.iter().zip(&gnss) {
        let (Event::Gnss(a), Event::Gnss(b)) = (a, b) else {
            unreachable!()
        };
        assert!((a.t - b.t).abs() < 1e-6);
        assert!((a.lat - b.lat).abs() < 1e-9 && (a.h - b.h).abs() < 1e-3);
        assert!((a.std_ned.x - b.std_ned.x).abs() < 1e-3);
    }
    let hd = pick(&got, |e| matches!(e, Event::Heading(_)));
    assert_eq!(hd.len(), 5);
    for (a, b) in pick(&ev, |e| matches!(e, Event::Heading(_)))
        .iter()
        .zip(&hd)
    {
        let (Event::Heading(a), Event::Heading(b)) = (a, b) else {
            unreachable!()
        };
        assert!((a.t - b.t).abs() < 1e-6);
        assert!(
            (a.heading_rad - b.heading_rad).abs() < 1e-6,
            "{} {}",
            a.heading_rad,
            b.heading_rad
        );
        assert!((a.pitch_rad - b.pitch_rad).abs() < 1e-3);
        assert!((a.std_heading_rad / b.std_heading_rad - 1.0).abs() < 0.01);
        assert!((a.baseline_m - b.baseline_m).abs() < 1e-3);
    }
    let odo = pick(&got, |e| matches!(e, Event::Odometer(_)));
    // The first tick count only starts the interval.
    assert_eq!(odo.len(), 49);
    for o in &odo {
        let Event::Odometer(o) = o else {
            unreachable!()
        };
        assert!((o.dt - 0.1).abs() < 1e-6);
        assert!(
            (o.speed_mps - 5.0).abs() <= M_PER_TICK / 0.1 + 1e-9,
            "{}",
            o.speed_mps
        );
    }
    let st = c.stats();
    assert!(st.is_balanced(), "{st}");
    // The date-only NAV-PVT before the first event.
    assert_eq!(st.rejected_for(REASON_NO_FIX), 1);
    assert_eq!(st.rejected_total(), 1);
}

#[test]
fn unrelatable_sensor_time_is_rejected_not_guessed() {
    // ESF-RAW before any anchor: six words rejected; no event.
    let data = [14u8, 13, 5, 16, 17, 18]
        .map(|t| {
            (
                EsfData {
                    data_type: t,
                    value: 1,
                },
                5u32,
            )
        })
        .to_vec();
    let bytes = encode(&UbxMessage::EsfRaw(EsfRaw { data }));
    let (got, c) = convert(&bytes, cfg());
    assert!(got.is_empty());
    assert_eq!(c.stats().rejected_for(REASON_NO_TIME), 6);
    // An anchor far from the samples (> MAX_EXTRAPOLATION_S): rejected too.
    let ev = drive(1);
    let mut bytes = to_bytes(&ev, None);
    let far = [14u8, 13, 5, 16, 17, 18]
        .map(|t| {
            (
                EsfData {
                    data_type: t,
                    value: 1,
                },
                1u32,
            )
        })
        .to_vec();
    bytes.extend(encode(&UbxMessage::EsfRaw(EsfRaw { data: far })));
    let (_, c) = convert(&bytes, cfg());
    assert_eq!(c.stats().rejected_for(REASON_NO_TIME), 6);
    assert!(c.stats().is_balanced());
}

#[test]
fn incomplete_sets_ticks_without_scale_and_invalid_relposned_are_counted() {
    let ev = drive(1);
    let mut bytes = to_bytes(&ev, None);
    let (good, _) = convert(&bytes, cfg());
    let t_tag = u32::MAX - 100_000 + 2000; // 2 s into the drive: still near the anchor
    let part = [14u8, 13, 5]
        .map(|t| {
            (
                EsfData {
                    data_type: t,
                    value: 1,
                },
                t_tag,
            )
        })
        .to_vec();
    bytes.extend(encode(&UbxMessage::EsfRaw(EsfRaw { data: part })));
    let rel = NavRelPosNed {
        version: 1,
        flags: 0x4,
        rel_pos_n_cm: 100,
        acc_heading_e5: 1000,
        ..Default::default()
    };
    bytes.extend(encode(&UbxMessage::NavRelPosNed(rel)));
    let rel_float_no_carrier = NavRelPosNed {
        flags: 0x4 | (1 << 8),
        ..rel
    };
    bytes.extend(encode(&UbxMessage::NavRelPosNed(rel_float_no_carrier)));
    let (got, c) = convert(&bytes, cfg());
    assert_eq!(got.len(), good.len());
    let st = c.stats();
    assert_eq!(st.rejected_for(REASON_INCOMPLETE), 3);
    assert_eq!(st.rejected_for(REASON_REL_INVALID), 1);
    assert_eq!(st.rejected_for(REASON_REL_NO_CARRIER), 1);
    // No metres_per_tick: the 10 tick words are rejected, no odometer event.
    let (got, c) = convert(&to_bytes(&ev, None), UbxEventsConfig::default());
    assert!(!got.iter().any(|e| matches!(e, Event::Odometer(_))));
    assert_eq!(c.stats().rejected_for(REASON_NO_TICK_SCALE), 10);
    assert!(c.stats().is_balanced());
}

#[test]
fn speed_type_is_signed_millimetres_per_second() {
    let ev = drive(1);
    let mut bytes = to_bytes(&ev, None);
    let tag = u32::MAX - 100_000 + 500;
    let v = EsfData {
        data_type: 11,
        value: (-1234i32 as u32) & 0xFF_FFFF,
    };
    bytes.extend(encode(&UbxMessage::EsfRaw(EsfRaw {
        data: vec![(v, tag)],
    })));
    let (got, _) = convert(&bytes, cfg());
    let Some(Event::Odometer(o)) = got.last() else {
        panic!("no speed event")
    };
    assert_eq!((o.speed_mps, o.dt, o.wheel), (-1.234, 0.0, 0));
}

/// For other modules' tests: the drive of this file and its bytes.
pub(crate) fn drive_for_tests(secs: usize) -> Vec<Event> {
    drive(secs)
}
pub(crate) fn to_bytes_for_tests(ev: &[Event]) -> Vec<u8> {
    to_bytes(ev, None)
}
