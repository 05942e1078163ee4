//! The two decode paths held to one contract: the compiled path (code the
//! build generates from the layout, `codec::compiled`) may only ever say
//! "mine, and here is the answer the general path gives" or "not mine".
//! [`agree`] checks exactly that on one datagram; the `decode_paths` fuzz
//! target ([`decode_paths`]) and `tests/compiled.rs` call it.

use crate::layouts::{anydevice, every_type as et, several, udptest};
use rri_firmware::codec::{decode, decode_general, DecodeError, Decoded};
use rri_firmware::schema::{FieldMut, MessageCodec};
use rri_firmware::value::{Frame, RriString, Time};
use std::fmt::Debug;

/// What both paths made of one datagram.
#[derive(Debug)]
pub struct Agreed<D> {
    /// The compiled path's answer: `None` when it handed the datagram over.
    pub compiled: Option<Decoded>,
    /// The general path's answer (the shipped `decode`'s too).
    pub general: Result<Decoded, DecodeError>,
    /// The record after the general path.
    pub data: D,
}

/// Decodes `bytes` as `M` three ways from the same previous record `prior`
/// (the compiled path alone, the general path alone, and `decode`, which
/// ships both) and panics where they disagree: when the compiled path
/// takes a datagram, the general path must accept it with the same
/// header, tally and record; `decode` must always answer as the general
/// path does, and leave the same record when it accepts. Records are
/// compared by their `Debug` text, so `-0.0` and `0.0` differ.
pub fn agree<M: MessageCodec>(bytes: &[u8], prior: &M::Data) -> Agreed<M::Data>
where
    M::Data: Clone + Debug,
{
    let mut general_data = prior.clone();
    let general = decode_general::<M>(bytes, &mut general_data);
    let mut shipped_data = prior.clone();
    let shipped = decode::<M>(bytes, &mut shipped_data);
    let text = || String::from_utf8_lossy(bytes).into_owned();
    assert_eq!(
        shipped,
        general,
        "decode and the general path differ on {:?}",
        text()
    );
    if general.is_ok() {
        assert_eq!(
            format!("{shipped_data:?}"),
            format!("{general_data:?}"),
            "decode left another record than the general path on {:?}",
            text()
        );
    }
    let mut compiled_data = prior.clone();
    let compiled = if bytes.len() <= M::MAX_RECEIVE_LEN {
        M::decode_compiled(bytes, &mut compiled_data)
    } else {
        None
    };
    if let Some(d) = compiled {
        assert_eq!(
            Ok(d),
            general,
            "the compiled path took {:?} with another answer than the general path",
            text()
        );
        assert_eq!(
            format!("{compiled_data:?}"),
            format!("{general_data:?}"),
            "the compiled path took {:?} into another record",
            text()
        );
    }
    Agreed {
        compiled,
        general,
        data: general_data,
    }
}

/// A previous record with every value set and none at its default, so a
/// value a message leaves out shows (M2): every real 7.25, every time
/// 3.5 s, bools `true`, strings `prior`, frames and joints 1..6, enums
/// their last member.
pub fn prior<M: MessageCodec>() -> M::Data
where
    M::Data: Default,
{
    let mut data = M::Data::default();
    for i in 0..M::FIELDS.len() {
        let Some(field) = M::field_mut(&mut data, i) else {
            break;
        };
        let s = || RriString::try_from("prior").expect("fits");
        match field {
            FieldMut::Bool(v) => *v = true,
            FieldMut::Real(v) => *v = 7.25,
            FieldMut::Time(v) => *v = Time::from_micros(3_500_000),
            FieldMut::Str(v) => *v = s(),
            FieldMut::Enum(_) => {}
            FieldMut::Frame(f) => {
                *f = Frame {
                    x: 1.0,
                    y: 2.0,
                    z: 3.0,
                    rx: 4.0,
                    ry: 5.0,
                    rz: 6.0,
                }
            }
            FieldMut::Joints(j) => *j = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
            FieldMut::Bools(a) => a.fill(true),
            FieldMut::Reals(a) => a.fill(7.25),
            FieldMut::Times(a) => a.fill(Time::from_micros(3_500_000)),
            FieldMut::Strs(a) => a.fill(s()),
        }
    }
    data
}

/// The `decode_paths` fuzz target: the first byte picks a property the
/// controller sends (of the manual's, the real-world, the every-type and
/// the several-properties layouts), the rest is the datagram, decoded
/// from a default record and from [`prior`]; [`agree`] must hold.
pub fn decode_paths(data: &[u8]) {
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    fn both<M: MessageCodec>(bytes: &[u8])
    where
        M::Data: Default + Clone + Debug,
    {
        agree::<M>(bytes, &M::Data::default());
        agree::<M>(bytes, &prior::<M>());
    }
    match pick % 8 {
        0 => both::<anydevice::RobDataMessage>(bytes),
        1 => both::<udptest::RsRobDataMessage>(bytes),
        2 => both::<et::RsRobDataMessage>(bytes),
        3 => both::<et::SharedMessage>(bytes),
        4 => both::<et::SpeedMessage>(bytes),
        5 => both::<several::RobDataMessage>(bytes),
        6 => both::<several::SpeedMessage>(bytes),
        _ => both::<several::ToolMessage>(bytes),
    }
}

/// Seeds of `decode_paths`: what controllers send (the manual's message,
/// compact and as printed; the IRC5 capture; the maximum values), the
/// same with a declaration, whitespace inside tags and a comment (one the
/// compiled path takes, one it hands over), and our encoder's message of
/// [`prior`] for every other property.
pub fn seeds() -> Vec<Vec<u8>> {
    use rri_firmware::codec::encode;
    let rri = crate::shared_rri();
    let read =
        |p: &std::path::Path| std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let bench = crate::workspace().join("host-tests/bench");
    let manual = read(&rri.join("examples/messages/RobData.xml"));
    let text = String::from_utf8_lossy(&manual).into_owned();
    let mut all: Vec<Vec<u8>> = vec![
        [&[0u8][..], &manual].concat(),
        [&[0u8][..], &read(&bench.join("RobData-compact.xml"))].concat(),
        [&[0u8][..], &read(&bench.join("RobData-max.xml"))].concat(),
        [
            &[1u8][..],
            &read(&rri.join("real-world/captured-RobData.xml")),
        ]
        .concat(),
    ];
    for variant in [
        format!("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\r\n{text}"),
        text.replace("<Ts_act>", "<Ts_act >")
            .replace("\" />", "\"\t/>"),
        text.replace("</RobData>", "<!-- end --></RobData>"),
    ] {
        all.push([&[0u8][..], variant.as_bytes()].concat());
    }
    fn ours<M: MessageCodec>(pick: u8) -> Vec<u8>
    where
        M::Data: Default,
    {
        let mut buf = vec![0u8; M::MAX_ENCODED_LEN];
        let e = encode::<M>(
            &prior::<M>(),
            42,
            Time::from_micros(1_500),
            rri_firmware::schema::Format::new(3, 3),
            &mut buf,
        )
        .expect("MAX_ENCODED_LEN holds any value");
        [&[pick][..], &buf[..e.len]].concat()
    }
    all.extend([
        ours::<et::RsRobDataMessage>(2),
        ours::<et::SharedMessage>(3),
        ours::<et::SpeedMessage>(4),
        ours::<several::RobDataMessage>(5),
        ours::<several::SpeedMessage>(6),
        ours::<several::ToolMessage>(7),
    ]);
    all
}
