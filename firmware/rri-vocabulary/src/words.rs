//! The closed word lists of the GSI files (G2, G3) that the firmware also
//! needs: each is one Rust type with its GSI spelling, so the compiler that
//! reads the files and the firmware that acts on them cannot disagree.

/// Whether the attribute value `text` is the GSI keyword `word`: keywords
/// match in any case, around whitespace (G2, G3). The one definition, for
/// these types and gsi-config's other keywords alike.
pub fn is_keyword(text: &str, word: &str) -> bool {
    word.eq_ignore_ascii_case(text.trim())
}

/// Finds the member of `all` whose GSI spelling is `text` ([`is_keyword`]).
fn from_gsi<T: Copy>(all: &[T], spell: fn(T) -> &'static str, text: &str) -> Option<T> {
    all.iter().copied().find(|w| is_keyword(text, spell(*w)))
}

/// Transport of the cyclic channel (G2, Description.xml
/// `<Channel Protocol>`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Protocol {
    /// `Udp`: one message per datagram.
    Udp,
    /// `Tcp`: messages back to back on a stream (M10 framing).
    Tcp,
    /// `HpUdp`: the controller's high-priority UDP path; plain UDP on the
    /// wire, only the controller's side differs.
    HpUdp,
}

impl Protocol {
    /// Every transport, in the manual's order.
    pub const ALL: [Protocol; 3] = [Protocol::Udp, Protocol::Tcp, Protocol::HpUdp];

    /// The GSI spelling.
    pub const fn as_str(self) -> &'static str {
        match self {
            Protocol::Udp => "Udp",
            Protocol::Tcp => "Tcp",
            Protocol::HpUdp => "HpUdp",
        }
    }

    /// The transport spelled `text` in a GSI file (any case).
    pub fn from_gsi(text: &str) -> Option<Protocol> {
        from_gsi(&Self::ALL, Self::as_str, text)
    }

    /// True for both UDP flavours: one message per datagram, no M10
    /// framing.
    pub const fn is_udp(self) -> bool {
        matches!(self, Protocol::Udp | Protocol::HpUdp)
    }
}

/// The controller's physical Ethernet port (G2, Description.xml
/// `<Network Port>`). Informational for the device: it tells the
/// integrator which socket of the cabinet the sensor is cabled to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ControllerPort {
    /// The LAN port (the default when `Port` is omitted).
    Lan,
    /// The service port.
    Service,
    /// Axis computer port 1.
    Axc1,
    /// Axis computer port 2.
    Axc2,
    /// Axis computer port 3.
    Axc3,
    /// Axis computer port 4.
    Axc4,
}

impl ControllerPort {
    /// Every port, in the manual's order.
    pub const ALL: [ControllerPort; 6] = [
        ControllerPort::Lan,
        ControllerPort::Service,
        ControllerPort::Axc1,
        ControllerPort::Axc2,
        ControllerPort::Axc3,
        ControllerPort::Axc4,
    ];

    /// The GSI spelling.
    pub const fn as_str(self) -> &'static str {
        match self {
            ControllerPort::Lan => "Lan",
            ControllerPort::Service => "Service",
            ControllerPort::Axc1 => "Axc1",
            ControllerPort::Axc2 => "Axc2",
            ControllerPort::Axc3 => "Axc3",
            ControllerPort::Axc4 => "Axc4",
        }
    }

    /// The port spelled `text` in a GSI file (any case).
    pub fn from_gsi(text: &str) -> Option<ControllerPort> {
        from_gsi(&Self::ALL, Self::as_str, text)
    }
}

/// Which way a property travels: G3's `Flag`, which the manual words from
/// RAPID's side (`ReadOnly`: RAPID only reads it, so the device sends it).
/// Named for the wire here so that nobody has to translate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Direction {
    /// `Flag="None"`: travels in neither direction.
    None,
    /// `Flag="WriteOnly"`: the controller sends it to the device.
    RobotToDevice,
    /// `Flag="ReadOnly"`: the device sends it to the controller.
    DeviceToRobot,
    /// `Flag="ReadWrite"`, also when `Flag` is omitted: both ways.
    #[default]
    Both,
}

impl Direction {
    /// Every direction, in the manual's order of `Flag` values.
    pub const ALL: [Direction; 4] = [
        Direction::None,
        Direction::DeviceToRobot,
        Direction::RobotToDevice,
        Direction::Both,
    ];

    /// The GSI `Flag` spelling.
    pub const fn flag(self) -> &'static str {
        match self {
            Direction::None => "None",
            Direction::DeviceToRobot => "ReadOnly",
            Direction::RobotToDevice => "WriteOnly",
            Direction::Both => "ReadWrite",
        }
    }

    /// The direction of `Flag="text"` (any case).
    pub fn from_flag(text: &str) -> Option<Direction> {
        from_gsi(&Self::ALL, Self::flag, text)
    }

    /// The controller sends this property to the device.
    pub const fn robot_sends(self) -> bool {
        matches!(self, Direction::RobotToDevice | Direction::Both)
    }

    /// The device sends this property to the controller.
    pub const fn device_sends(self) -> bool {
        matches!(self, Direction::DeviceToRobot | Direction::Both)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn g2_words_round_trip_in_any_case() {
        for p in Protocol::ALL {
            assert_eq!(Protocol::from_gsi(p.as_str()), Some(p));
        }
        for p in ControllerPort::ALL {
            assert_eq!(ControllerPort::from_gsi(p.as_str()), Some(p));
        }
        assert_eq!(Protocol::from_gsi(" hpudp "), Some(Protocol::HpUdp));
        assert_eq!(ControllerPort::from_gsi("AXC3"), Some(ControllerPort::Axc3));
        assert_eq!(Protocol::from_gsi("Sctp"), None);
        assert_eq!(ControllerPort::from_gsi("Axc5"), None);
    }

    #[test]
    fn g3_flags_are_read_from_rapids_side() {
        assert_eq!(
            Direction::from_flag("readonly"),
            Some(Direction::DeviceToRobot)
        );
        assert_eq!(
            Direction::from_flag("WriteOnly"),
            Some(Direction::RobotToDevice)
        );
        assert_eq!(Direction::from_flag("Write"), None);
        assert_eq!(Direction::default(), Direction::Both);
        let sends: [(bool, bool); 4] = Direction::ALL.map(|d| (d.robot_sends(), d.device_sends()));
        assert_eq!(
            sends,
            [(false, false), (false, true), (true, false), (true, true)]
        );
        for d in Direction::ALL {
            assert_eq!(Direction::from_flag(d.flag()), Some(d));
        }
    }

    #[test]
    fn g2_g3_keywords_match_in_any_case_around_whitespace() {
        assert!(is_keyword(" cdp\t", "CDP"));
        assert!(is_keyword("Cyclic", "cyclic"));
        assert!(!is_keyword("Cyc lic", "Cyclic"));
        assert!(!is_keyword("", "Intern"));
    }

    #[test]
    fn only_udp_flavours_are_udp() {
        assert!(Protocol::Udp.is_udp() && Protocol::HpUdp.is_udp());
        assert!(!Protocol::Tcp.is_udp());
    }
}
