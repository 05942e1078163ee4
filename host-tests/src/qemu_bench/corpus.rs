//! The bench's corpora: the realistic messages (the manual's, an IRC5
//! capture, maximum values) and the hostile ones (every input exactly
//! `MAX_RECEIVE_LEN` bytes, each built to cost the decoder the most).

use crate::layouts::anydevice as layout;

/// One corpus message. `{ID}` in `text` is replaced by a fresh 10-digit
/// Id for every send (so the length never changes).
#[derive(Clone, Debug)]
pub struct Input {
    pub name: String,
    pub text: String,
    /// The decoder must accept it (and the device answer it).
    pub accepted: bool,
}

impl Input {
    pub fn with_id(&self, id: u32) -> Vec<u8> {
        self.text.replace("{ID}", &format!("{id:010}")).into_bytes()
    }

    pub fn len(&self) -> usize {
        self.with_id(0).len()
    }

    pub fn is_empty(&self) -> bool {
        self.text.is_empty()
    }
}

/// Puts the `{ID}` placeholder in place of a message's `Id` value.
pub fn templated(message: &str) -> String {
    match (
        message.find("Id=\""),
        message
            .find("Id=\"")
            .and_then(|i| message[i + 4..].find('"')),
    ) {
        (Some(i), Some(len)) => format!(
            "{}Id=\"{{ID}}\"{}",
            &message[..i],
            &message[i + 4 + len + 1..]
        ),
        _ => message.to_string(),
    }
}

/// The manual's message, the real IRC5 capture and the maximum-value
/// message.
pub fn realistic(
    shared_rri: &std::path::Path,
    bench_dir: &std::path::Path,
) -> Result<Vec<Input>, String> {
    let files = [
        (
            "manual RobData",
            shared_rri.join("examples/messages/RobData.xml"),
        ),
        (
            "IRC5 capture",
            shared_rri.join("real-world/captured-RobData.xml"),
        ),
        ("maximum values", bench_dir.join("RobData-max.xml")),
    ];
    files
        .iter()
        .map(|(name, path)| {
            let text =
                std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
            Ok(Input {
                name: name.to_string(),
                text: templated(&text),
                accepted: true,
            })
        })
        .collect()
}

/// The manual's message without whitespace between elements.
fn compact_manual() -> String {
    templated(include_str!("../../bench/RobData-compact.xml"))
}

/// Fills `open` + `unit`* + `close` to exactly `total` bytes (the unit
/// repeated, then `filler` bytes of spaces).
fn fill(open: &str, unit: &str, close: &str, total: usize) -> String {
    // `{ID}` becomes 10 digits on the wire.
    let wire = |s: &str| s.len() + 6 * s.matches("{ID}").count();
    let room = total.saturating_sub(wire(open) + wire(close));
    let n = room / unit.len().max(1);
    let mut s = String::with_capacity(total);
    s.push_str(open);
    for _ in 0..n {
        s.push_str(unit);
    }
    s.push_str(&" ".repeat(room - n * unit.len()));
    s.push_str(close);
    s
}

/// The most expensive inputs the decoder accepts or rejects late, each
/// exactly `layout::MAX_RECEIVE_LEN` bytes (longer ones are rejected at
/// once by length). Those the decoder rejects early (too many extras, a
/// repeated field) stay in the corpus: the bench shows what they cost now.
pub fn hostile() -> Vec<Input> {
    let max = layout::MAX_RECEIVE_LEN;
    let manual = compact_manual();
    let (head, rest) = manual.split_at(manual.find("><").map(|i| i + 1).unwrap_or(0));
    let body_end = rest.rfind("</RobData>").unwrap_or(rest.len());
    let (body, close) = rest.split_at(body_end);
    let inside = |unit: &str, tail: &str| fill(head, unit, &format!("{body}{tail}{close}"), max);
    // An f32 halfway case as long as a number may be (MAX_NUMBER_LEN): its
    // exact decimal expansion, then digits that only the last place
    // decides (the exact slow path of the number parser).
    let halfway = format!(
        "1.000000059604644775390625{}1",
        "0".repeat(rri_firmware::codec::number::MAX_NUMBER_LEN - 27)
    );
    assert_eq!(halfway.len(), rri_firmware::codec::number::MAX_NUMBER_LEN);
    let attrs = |names: &[&str]| -> String {
        names
            .iter()
            .map(|n| format!(" {n}=\"{halfway}\""))
            .collect()
    };
    let frame = attrs(&["X", "Y", "Z", "Rx", "Ry", "Rz"]);
    let joints = attrs(&["J1", "J2", "J3", "J4", "J5", "J6"]);
    let app: Vec<String> = (1..=18).map(|i| format!("X{i}")).collect();
    let app = attrs(&app.iter().map(String::as_str).collect::<Vec<_>>());
    // Every real of the layout once, each a halfway case: the most slow
    // paths a message without repeats can hold.
    let every_real_halfway = fill(
        &format!(
            "<RobData Id=\"{{ID}}\" Ts=\"1.202\"><P_act{frame}/><J_act{joints}/><P_des{frame}/><J_des{joints}/><AppData{app}/>"
        ),
        " ",
        "</RobData>",
        max,
    );
    let repeated_field = {
        let s = format!("<RobData Id=\"{{ID}}\" Ts=\"1.202\"><AppData{app}/>");
        fill(&s, &format!("<P_act{frame}/>"), "</RobData>", max)
    };
    // One number as long as the datagram allows: refused unread.
    let one_long_number = {
        let open = "<RobData Id=\"{ID}\" Ts=\"1.202\"><AppData X1=\"1.";
        fill(open, "0", "1\"/></RobData>", max)
    };
    // Whitespace inside a field of attributes, where each attribute the
    // layout expects is tried after it (the review of issue 36: 348,540
    // instructions before each run was read once).
    let spaced_attrs = |open: &str| {
        fill(
            &format!("<RobData Id=\"{{ID}}\" Ts=\"1.202\"><AppData{open}"),
            " ",
            "/></RobData>",
            max,
        )
    };
    vec![
        Input {
            name: "whitespace among attributes".into(),
            text: spaced_attrs(""),
            accepted: true,
        },
        Input {
            name: "whitespace after an attribute".into(),
            text: spaced_attrs(" X1=\"1\""),
            accepted: true,
        },
        Input {
            name: "whitespace padding".into(),
            text: fill(head, " ", &format!("{body}{close}"), max),
            accepted: true,
        },
        Input {
            name: "handed over late".into(),
            // The same, its last byte wrong (issue 36, finding 2): the
            // compiled path reads it all, then hands it over; the general
            // path resumes at its last field and takes its reals as read.
            text: format!(
                "{}x",
                every_real_halfway
                    .strip_suffix('>')
                    .unwrap_or(&every_real_halfway)
            ),
            accepted: false,
        },
        Input {
            name: "every real a halfway case".into(),
            text: every_real_halfway,
            accepted: true,
        },
        Input {
            name: "entity references".into(),
            text: inside("", &fill("<U>", "&amp;", "</U>", max / 2)),
            accepted: true,
        },
        Input {
            name: "one long number".into(),
            text: one_long_number,
            accepted: false,
        },
        Input {
            name: "repeated field".into(),
            text: repeated_field,
            accepted: false,
        },
        Input {
            name: "unknown attributes".into(),
            text: fill(
                "<RobData Id=\"{ID}\" Ts=\"1.202\"",
                " u=\"1\"",
                "></RobData>",
                max,
            ),
            accepted: false,
        },
        Input {
            name: "unknown empty elements".into(),
            text: inside("<U/>", ""),
            accepted: false,
        },
        Input {
            name: "attributes of an unknown element".into(),
            text: inside("", &fill("<U", " u=\"1\"", "/>", max / 2)),
            accepted: false,
        },
        Input {
            name: "comments".into(),
            text: inside("<!---->", ""),
            accepted: false,
        },
        Input {
            name: "processing instructions".into(),
            text: inside("<?p?>", ""),
            accepted: false,
        },
        Input {
            name: "rejected at the last byte".into(),
            text: {
                let ok = fill(head, " ", &format!("{body}{close}"), max);
                // A bad number in the last attribute of the last element.
                let i = ok.rfind("Rz=\"").map(|i| i + 4).unwrap_or(0);
                format!("{}x{}", &ok[..i], &ok[i + 1..])
            },
            accepted: false,
        },
        Input {
            name: "truncated".into(),
            text: fill(head, " ", body, max),
            accepted: false,
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hostile_inputs_are_exactly_the_receive_bound() {
        for input in hostile() {
            assert_eq!(input.len(), layout::MAX_RECEIVE_LEN, "{}", input.name);
            assert!(
                input.text.contains("{ID}") || !input.accepted,
                "{}",
                input.name
            );
        }
    }

    #[test]
    fn accepted_hostile_inputs_decode_and_rejected_ones_do_not() {
        use rri_firmware::codec::decode;
        for input in hostile() {
            let mut robot = layout::RobotData::default();
            let r = decode::<layout::RobDataMessage>(&input.with_id(7), &mut robot);
            assert_eq!(r.is_ok(), input.accepted, "{}: {r:?}", input.name);
        }
    }
}
