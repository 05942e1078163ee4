#!/usr/bin/env bash
# Makes the replay fixtures in this folder: real capture tools (tcpdump and
# tshark, not our writer) recording a robot simulator <-> host sensor
# session, the manual's AnyDevice, 100 robot messages each, with unrelated
# traffic in the same file (ICMP, UDP to another port, HTTP to the sensor's
# diagnostics). Each runs in a network namespace of its own (root), so
# nothing else on the machine is in them, and the last one with a loopback
# MTU of 576 so that every robot message goes in IPv4 fragments.
#
#   udp-lo.pcap           tcpdump -i lo, Ethernet, microseconds, pcap
#   udp-any.pcapng        tshark -i any, Linux cooked (SLL2), pcapng
#   tcp-lo.pcap           tcpdump -i lo --time-stamp-precision=nano, the
#                         channel over TCP (M10 framing), nanosecond pcap
#   fragmented-lo.pcapng  tshark -i lo, MTU 576: robot messages in fragments
#
# Needs: tcpdump, tshark, iproute2; cargo build --release -p host-tests
# --bin sensor-host -p rri-robot --bin robot (the default configuration).
set -euo pipefail
cd "$(dirname "$0")/../.."
here=host-tests/captures
gsi=firmware/gsi/GSI
sensor=$PWD/target/release/sensor-host
robot=$PWD/target/release/robot

session() { # name tool link mtu transport
    local name=$1 tool=$2 link=$3 mtu=$4 transport=$5 ns=rri-capture
    ip netns del $ns 2>/dev/null || true
    ip netns add $ns
    ip -n $ns link set lo mtu "$mtu" up
    local out=$PWD/$here/$name
    rm -f "$out"
    case $tool in
        tcpdump-us) ip netns exec $ns tcpdump -q -i "$link" -s 0 -w "$out" 2>/dev/null & ;;
        tcpdump-ns) ip netns exec $ns tcpdump -q -i "$link" -s 0 --time-stamp-precision=nano -w "$out" 2>/dev/null & ;;
        tshark) ip netns exec $ns tshark -q -i "$link" -s 0 -F pcapng -w "$out" 2>/dev/null & ;;
    esac
    local cap=$!
    sleep 2
    ip netns exec $ns "$sensor" --listen 127.0.0.1:3002 --"$transport" --http 127.0.0.1:8080 >/dev/null &
    local sen=$!
    sleep 1
    # Unrelated traffic before, during and after.
    ip netns exec $ns ping -c 2 -i 0.2 127.0.0.1 >/dev/null || true
    ip netns exec $ns bash -c 'echo not-rri > /dev/udp/127.0.0.1/9999' || true
    ip netns exec $ns bash -c 'exec 3<>/dev/tcp/127.0.0.1/8080; printf "GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n" >&3; cat <&3 >/dev/null' || true
    local tcp=""
    [ "$transport" = tcp ] && tcp=--tcp
    ip netns exec $ns "$robot" --gsi $gsi --to 127.0.0.1:3002 $tcp --cycles 100 --no-progress >/dev/null
    ip netns exec $ns bash -c 'echo not-rri-either > /dev/udp/127.0.0.1/9999' || true
    sleep 1
    kill $sen
    sleep 1
    kill -INT $cap
    wait $cap 2>/dev/null || true
    ip netns del $ns
    echo "$name: $(stat -c %s "$out") bytes"
}

session udp-lo.pcap tcpdump-us lo 65536 udp
session udp-any.pcapng tshark any 65536 udp
session tcp-lo.pcap tcpdump-ns lo 65536 tcp
session fragmented-lo.pcapng tshark lo 576 udp
