//! S2: the device's sensor state, mirroring RAPID's `sensorstate`.

/// RAPID's `sensorstate` values (S2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SensorState {
    /// `STATE_ERROR = -1`, with an [`ErrorCode`].
    Error,
    /// `STATE_UNDEFINED = 0`: the network is not up yet.
    #[default]
    Undefined,
    /// `STATE_CONNECTED = 1`: listening (UDP) or a TCP peer connected.
    Connected,
    /// `STATE_OPERATING = 2`: robot messages arrive within `TimeOut`.
    Operating,
    /// `STATE_CLOSED = 3`: the TCP peer closed the connection.
    Closed,
}

impl SensorState {
    /// The RAPID value.
    pub const fn rapid_value(self) -> i8 {
        match self {
            SensorState::Error => -1,
            SensorState::Undefined => 0,
            SensorState::Connected => 1,
            SensorState::Operating => 2,
            SensorState::Closed => 3,
        }
    }

    /// RAPID's name without the `STATE_` prefix, for logs.
    pub const fn name(self) -> &'static str {
        match self {
            SensorState::Error => "ERROR",
            SensorState::Undefined => "UNDEFINED",
            SensorState::Connected => "CONNECTED",
            SensorState::Operating => "OPERATING",
            SensorState::Closed => "CLOSED",
        }
    }
}

/// The controller's error codes for `STATE_ERROR` (S2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ErrorCode {
    /// 112600: interface initialisation failed (the transport could not
    /// open its socket).
    InitFailed,
    /// 112602: communication error (`TimeOut` or `MaxLost` exceeded).
    Communication,
}

impl ErrorCode {
    /// The number the controller reports (S2).
    pub const fn code(self) -> u32 {
        match self {
            ErrorCode::InitFailed => 112_600,
            ErrorCode::Communication => 112_602,
        }
    }
}
