//! The bridge's UDP: datagrams framed for the device (fragments of 1,480
//! payload bytes, RFC 791; an ARP request first while the device's MAC is
//! unknown) and the device's datagrams reassembled by identification.

use super::{Bridge, GATEWAY_MAC, MTU, ROBOT_PORT};
use smoltcp::wire::{
    ArpOperation, ArpPacket, EthernetAddress, EthernetFrame, EthernetProtocol, IpAddress,
    IpProtocol, Ipv4Packet, UdpPacket,
};

impl Bridge {
    /// A UDP datagram (or a fragment of one) from the device.
    pub(super) fn udp_fragment(&mut self, id: u16, offset: usize, payload: Vec<u8>, more: bool) {
        let whole = if offset == 0 && !more {
            payload
        } else {
            let parts = self.reassembly.entry(id).or_default();
            parts.push((offset, payload, more));
            parts.sort_by_key(|p| p.0);
            let mut data = Vec::new();
            let mut complete = false;
            for (off, p, m) in parts.iter() {
                if *off != data.len() {
                    break;
                }
                data.extend_from_slice(p);
                if !*m {
                    complete = true;
                }
            }
            if !complete {
                return;
            }
            self.reassembly.remove(&id);
            data
        };
        let Ok(udp) = UdpPacket::new_checked(&whole[..]) else {
            return;
        };
        if self.internal {
            if udp.dst_port() == ROBOT_PORT {
                self.counts.udp_from_device += 1;
                self.replies.push_back(udp.payload().to_vec());
            }
            return;
        }
        let (Some((sock, _)), Some(client)) = (&self.udp, self.client) else {
            return;
        };
        if udp.dst_port() == ROBOT_PORT {
            self.counts.udp_from_device += 1;
            let _ = sock.send_to(udp.payload(), client);
        }
    }

    /// Frames a datagram to the device, in fragments when it is longer
    /// than one frame; before the device's MAC is known an ARP request
    /// goes first and the frames wait.
    pub(super) fn udp_to_device(&mut self, payload: &[u8], port: u16) {
        let mut udp = vec![0u8; 8 + payload.len()];
        {
            let mut p = UdpPacket::new_unchecked(&mut udp[..]);
            p.set_src_port(ROBOT_PORT);
            p.set_dst_port(port);
            p.set_len((8 + payload.len()) as u16);
            p.payload_mut().copy_from_slice(payload);
            p.fill_checksum(
                &IpAddress::Ipv4(self.gateway),
                &IpAddress::Ipv4(self.device),
            );
        }
        let id = self.ip_id;
        self.ip_id = self.ip_id.wrapping_add(1);
        let chunk = (MTU - 20) / 8 * 8;
        let mut offset = 0;
        while offset < udp.len() {
            let end = (offset + chunk).min(udp.len());
            let part = &udp[offset..end];
            let mut frame = vec![0u8; 14 + 20 + part.len()];
            {
                let mut eth = EthernetFrame::new_unchecked(&mut frame[..]);
                eth.set_dst_addr(self.device_mac.unwrap_or(EthernetAddress([0; 6])));
                eth.set_src_addr(EthernetAddress(GATEWAY_MAC));
                eth.set_ethertype(EthernetProtocol::Ipv4);
                let mut ip = Ipv4Packet::new_unchecked(eth.payload_mut());
                ip.set_version(4);
                ip.set_header_len(20);
                ip.set_dscp(0);
                ip.set_ecn(0);
                ip.set_total_len((20 + part.len()) as u16);
                ip.set_ident(id);
                ip.clear_flags();
                ip.set_more_frags(end < udp.len());
                ip.set_frag_offset(offset as u16);
                ip.set_hop_limit(64);
                ip.set_next_header(IpProtocol::Udp);
                ip.set_src_addr(self.gateway);
                ip.set_dst_addr(self.device);
                ip.payload_mut().copy_from_slice(part);
                ip.fill_checksum();
            }
            if self.device_mac.is_none() && offset == 0 {
                // Until the device answers (its link may still be coming
                // up), each datagram asks again.
                self.tx.push_back(self.arp_request());
            }
            self.tx.push_back(frame);
            offset = end;
        }
    }

    fn arp_request(&self) -> Vec<u8> {
        let mut frame = vec![0u8; 14 + 28];
        let mut eth = EthernetFrame::new_unchecked(&mut frame[..]);
        eth.set_dst_addr(EthernetAddress::BROADCAST);
        eth.set_src_addr(EthernetAddress(GATEWAY_MAC));
        eth.set_ethertype(EthernetProtocol::Arp);
        let mut arp = ArpPacket::new_unchecked(eth.payload_mut());
        arp.set_hardware_type(smoltcp::wire::ArpHardware::Ethernet);
        arp.set_protocol_type(EthernetProtocol::Ipv4);
        arp.set_hardware_len(6);
        arp.set_protocol_len(4);
        arp.set_operation(ArpOperation::Request);
        arp.set_source_hardware_addr(&GATEWAY_MAC);
        arp.set_source_protocol_addr(&self.gateway.octets());
        arp.set_target_hardware_addr(&[0; 6]);
        arp.set_target_protocol_addr(&self.device.octets());
        frame
    }
}
