//! Property tests of the codec over a configuration that uses every type
//! (host-tests/gsi/every-type): encode → decode gives the same values,
//! within the configured decimals (M5), and the decoder takes arbitrary
//! bytes without panicking, rejecting with an offset inside the input.

use host_tests::layouts::{anydevice, every_type as et};
use proptest::prelude::*;
use rri_firmware::codec::{decode, encode, Tally};
use rri_firmware::schema::{Message, MessageCodec};
use rri_firmware::value::{Frame, RriString, Time};

fn real() -> impl Strategy<Value = f32> {
    prop_oneof![
        -1.0e6f32..1.0e6,
        -1.0f32..1.0,
        Just(0.0f32),
        Just(-12_345.679_f32),
    ]
}

fn time() -> impl Strategy<Value = Time> {
    (-10_000_000_000_000i64..10_000_000_000_000).prop_map(Time::from_micros)
}

fn frame() -> impl Strategy<Value = Frame> {
    proptest::array::uniform6(real()).prop_map(|[x, y, z, rx, ry, rz]| Frame {
        x,
        y,
        z,
        rx,
        ry,
        rz,
    })
}

/// Any character XML 1.0 can carry (controls other than tab, LF, CR can
/// not be written at all, so the encoder replaces them).
fn xml_char() -> impl Strategy<Value = char> {
    any::<char>().prop_map(|c| {
        let u = c as u32;
        let writable =
            !(u < 0x20 && u != 0x9 && u != 0xA && u != 0xD) && u != 0xFFFE && u != 0xFFFF;
        if writable {
            c
        } else {
            'x'
        }
    })
}

fn string() -> impl Strategy<Value = RriString> {
    prop::collection::vec(
        prop_oneof![
            xml_char(),
            prop::sample::select(vec!['&', '<', '>', '"', '\'', ' ', 'a'])
        ],
        0..90,
    )
    .prop_map(|chars| {
        let mut s = RriString::new();
        for c in chars {
            if s.push(c).is_err() {
                break;
            }
        }
        s
    })
}

prop_compose! {
    fn robdata()(
        operation_mode in prop::sample::select(et::Opmode::MEMBERS.to_vec()),
        feedback_time in time(),
        feedback_pose in frame(),
        feedback_joints in proptest::array::uniform6(real()),
        enabled in any::<bool>(),
        gain in real(),
        note in string(),
        phase in prop::sample::select(et::Phase::MEMBERS.to_vec()),
        target in frame(),
        flags in proptest::array::uniform3(any::<bool>()),
        stamps in proptest::array::uniform2(time()),
        labels in proptest::array::uniform2(string()),
        app_data in proptest::array::uniform4(real()),
    ) -> et::Robdata {
        et::Robdata {
            operation_mode, feedback_time, feedback_pose, feedback_joints, enabled, gain,
            note, phase, target, flags, stamps, labels, app_data,
        }
    }
}

prop_compose! {
    fn sensdata()(
        status in string(),
        valid in any::<bool>(),
        distance in real(),
        measured in time(),
        correction in frame(),
        axes in proptest::array::uniform6(real()),
        phase in prop::sample::select(et::Phase::MEMBERS.to_vec()),
        app_data in proptest::array::uniform20(real()),
    ) -> et::Sensdata {
        et::Sensdata { status, valid, distance, measured, correction, axes, phase, app_data }
    }
}

/// M5: reals travel with 3 decimals: equal within half a unit of the last
/// decimal plus f32 rounding of the re-read value.
fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 0.0005 + a.abs() * 2.0e-7
}

fn close_time(a: Time, b: Time) -> bool {
    (a.as_micros() - b.as_micros()).abs() <= 500
}

fn close_frame(a: &Frame, b: &Frame) -> bool {
    close(a.x, b.x)
        && close(a.y, b.y)
        && close(a.z, b.z)
        && close(a.rx, b.rx)
        && close(a.ry, b.ry)
        && close(a.rz, b.rz)
}

fn all_close(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| close(*x, *y))
}

/// Encodes `data` as message `M`, decodes it into a default value and
/// returns what came back, checking the header and that nothing was
/// tolerated on the way.
fn round_trip<M: MessageCodec>(data: &M::Data, id: u32, ts: Time) -> M::Data
where
    M::Data: Default,
{
    let mut buf = vec![0u8; M::MAX_ENCODED_LEN];
    let out = encode::<M>(data, id, ts, et::FORMAT, &mut buf).expect("fits MAX_ENCODED_LEN");
    assert!(out.len <= M::MAX_ENCODED_LEN);
    assert!(out.len <= M::MAX_RECEIVE_LEN, "what we send, we accept");
    let mut back = M::Data::default();
    let d = decode::<M>(&buf[..out.len], &mut back)
        .unwrap_or_else(|e| panic!("{e:?} in {}", String::from_utf8_lossy(&buf[..out.len])));
    assert_eq!(d.id, id);
    assert!(close_time(d.ts.expect("Ts"), ts));
    assert_eq!(d.tally, Tally::default());
    back
}

proptest! {
    // 500 cases by default; PROPTEST_CASES=100000 for a longer soak.
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(500),
        ..ProptestConfig::default()
    })]

    #[test]
    fn robdata_every_type_round_trips(data in robdata(), id in any::<u32>(), ts in time()) {
        let back = round_trip::<et::RsRobDataMessage>(&data, id, ts);
        prop_assert_eq!(back.operation_mode, data.operation_mode);
        prop_assert!(close_time(back.feedback_time, data.feedback_time));
        prop_assert!(close_frame(&back.feedback_pose, &data.feedback_pose));
        prop_assert!(all_close(&back.feedback_joints, &data.feedback_joints));
        prop_assert_eq!(back.enabled, data.enabled);
        prop_assert!(close(back.gain, data.gain));
        prop_assert_eq!(&back.note, &data.note);
        prop_assert_eq!(back.phase, data.phase);
        prop_assert!(close_frame(&back.target, &data.target));
        prop_assert_eq!(back.flags, data.flags);
        prop_assert!(close_time(back.stamps[0], data.stamps[0]) && close_time(back.stamps[1], data.stamps[1]));
        prop_assert_eq!(&back.labels, &data.labels);
        prop_assert!(all_close(&back.app_data, &data.app_data));
    }

    #[test]
    fn sensdata_round_trips_both_ways(data in sensdata(), id in any::<u32>(), ts in time()) {
        // SensData (ReadOnly) and Shared (ReadWrite) carry the same record.
        for back in [
            round_trip::<et::RsSensDataMessage>(&data, id, ts),
            round_trip::<et::SharedMessage>(&data, id, ts),
        ] {
            prop_assert_eq!(&back.status, &data.status);
            prop_assert_eq!(back.valid, data.valid);
            prop_assert!(close(back.distance, data.distance));
            prop_assert!(close_time(back.measured, data.measured));
            prop_assert!(close_frame(&back.correction, &data.correction));
            prop_assert!(all_close(&back.axes, &data.axes));
            prop_assert_eq!(back.phase, data.phase);
            prop_assert!(all_close(&back.app_data, &data.app_data));
        }
    }

    #[test]
    fn value_properties_round_trip(speed in real(), offsets in proptest::array::uniform3(real()), id in any::<u32>()) {
        prop_assert!(close(round_trip::<et::SpeedMessage>(&speed, id, Time::ZERO), speed));
        prop_assert!(all_close(&round_trip::<et::OffsetsMessage>(&offsets, id, Time::ZERO), &offsets));
    }

    #[test]
    fn decoder_takes_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let mut data = anydevice::RobotData::default();
        if let Err(e) = decode::<anydevice::RobDataMessage>(&bytes, &mut data) {
            prop_assert!(e.offset <= bytes.len().max(anydevice::RobDataMessage::MAX_RECEIVE_LEN));
        }
    }

    #[test]
    fn decoder_takes_mutations_of_the_manual_message(
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>(), 0u8..3), 1..8)
    ) {
        let mut bytes = std::fs::read(host_tests::shared_rri().join("examples/messages/RobData.xml")).expect("manual");
        for (at, byte, op) in edits {
            let i = at.index(bytes.len().max(1));
            match op {
                0 if i < bytes.len() => bytes[i] = byte,
                1 => bytes.insert(i.min(bytes.len()), byte),
                _ if i < bytes.len() => { bytes.remove(i); }
                _ => {}
            }
        }
        let mut data = anydevice::RobotData::default();
        match decode::<anydevice::RobDataMessage>(&bytes, &mut data) {
            Ok(d) => prop_assert!(d.tally.missing_fields <= 8),
            Err(e) => prop_assert!(e.offset <= bytes.len()),
        }
    }
}
