//! The Ethernet wire between the chip's MAC and the outside (the network
//! bridge, or a test): whole frames each way, without the preamble and the
//! frame check sequence, which the MAC adds and strips.

use std::collections::VecDeque;

#[derive(Clone, Debug, Default)]
pub struct Link {
    /// Frames on their way to the MAC, in order.
    pub to_device: VecDeque<Vec<u8>>,
    /// Frames the MAC sent.
    pub from_device: VecDeque<Vec<u8>>,
    /// The PHY's receive clock runs (the LAN8742A's 50 MHz REF_CLK on the
    /// NUCLEO): without it the MAC's DMA never leaves its software reset.
    pub ref_clock: bool,
    /// The cable is in (the PHY reports the link once auto-negotiation
    /// completes).
    pub cable: bool,
    /// The MAC's receiver is on (MACCR.RE, as the MAC model last saw it
    /// written; off again at a reset): a frame from outside can reach the
    /// image, so a paced run keeps to the wall clock
    /// ([`crate::machine::pace`]).
    pub listening: bool,
}

impl Link {
    /// A NUCLEO's link: the PHY's clock running, the cable in.
    pub fn nucleo() -> Link {
        Link {
            ref_clock: true,
            cable: true,
            ..Link::default()
        }
    }
}
