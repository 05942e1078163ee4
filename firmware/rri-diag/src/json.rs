//! `/status.json`: the page's content for machines (schema
//! [`SCHEMA`]; every field is documented in the firmware's README). Times
//! are integers in µs of device time (since start), so nothing is a float.

use super::counters::FAMILIES;
use super::events::EventKind;
use super::out::Out;
use super::status::{Identity, Status};
use super::view;
use rri_firmware::codec::DecodeErrorKind;
use rri_firmware::engine::Endpoint;

/// The JSON layout's version: raised when a field changes meaning or
/// goes away (new fields do not raise it).
pub const SCHEMA: u32 = 1;

/// Writes an object's members with the commas between them.
struct Members<'o> {
    out: &'o mut dyn Out,
    first: bool,
}

impl<'o> Members<'o> {
    fn new(out: &'o mut dyn Out) -> Self {
        Members { out, first: true }
    }

    /// `"k":` after a comma where one is due; the value is the caller's.
    #[inline(never)]
    fn key(&mut self, k: &str) -> &mut dyn Out {
        if !self.first {
            self.out.str(",");
        }
        self.first = false;
        self.out.str("\"");
        self.out.str(k);
        self.out.str("\":");
        self.out
    }

    #[inline(never)]
    fn num(&mut self, k: &str, v: u64) {
        self.key(k).u64(v);
    }

    #[inline(never)]
    fn text(&mut self, k: &str, v: &str) {
        self.quoted(k, &mut |o| o.json(v));
    }

    #[inline(never)]
    fn flag(&mut self, k: &str, v: bool) {
        self.key(k).str(if v { "true" } else { "false" });
    }

    #[inline(never)]
    fn null(&mut self, k: &str) {
        self.key(k).str("null");
    }

    /// A number, or `null` where there is none.
    #[inline(never)]
    fn opt_num(&mut self, k: &str, v: Option<u64>) {
        match v {
            Some(v) => self.num(k, v),
            None => self.null(k),
        }
    }

    #[inline(never)]
    fn opt_flag(&mut self, k: &str, v: Option<bool>) {
        match v {
            Some(v) => self.flag(k, v),
            None => self.null(k),
        }
    }

    /// `"k":"…"`, the string's content written by `f` (escaped by it).
    #[inline(never)]
    fn quoted(&mut self, k: &str, f: &mut dyn FnMut(&mut dyn Out)) {
        let o = self.key(k);
        o.str("\"");
        f(o);
        o.str("\"");
    }

    #[inline(never)]
    fn endpoint(&mut self, k: &str, e: Option<Endpoint>) {
        match e {
            Some(e) => self.quoted(k, &mut |o| view::endpoint(o, e)),
            None => self.null(k),
        }
    }

    fn object(&mut self, k: &str, f: &mut dyn FnMut(&mut Members<'_>)) {
        self.key(k).str("{");
        let mut inner = Members::new(&mut *self.out);
        f(&mut inner);
        self.out.str("}");
    }

    /// `"k":[…]`, each item written by `item` (the commas are done here).
    fn array<T>(
        &mut self,
        k: &str,
        items: impl Iterator<Item = T>,
        item: &mut dyn FnMut(&mut dyn Out, T),
    ) {
        self.key(k).str("[");
        for (i, t) in items.enumerate() {
            if i > 0 {
                self.out.str(",");
            }
            item(self.out, t);
        }
        self.out.str("]");
    }
}

/// Writes `/status.json`.
pub fn write(out: &mut dyn Out, id: &Identity, s: &Status) {
    out.str("{");
    let mut m = Members::new(&mut *out);
    m.num("schema", SCHEMA.into());
    m.object("device", &mut |d| device(d, id, s));
    m.object("config", &mut |c| config(c, id));
    m.object("state", &mut |st| {
        let snap = &s.snapshot;
        st.text("state", snap.state.name());
        st.opt_num("error_code", snap.error.map(|e| e.code().into()));
        st.endpoint("peer", snap.peer);
        st.opt_num(
            "since_last_message_us",
            snap.last_message.map(|at| s.now.micros_since(at)),
        );
    });
    m.object("counters", &mut |c| counters(c, s, id.received.len()));
    m.object("latency", &mut |l| {
        let h = &s.latency.histogram;
        l.text("source", s.latency.source.name());
        l.num("count", h.count);
        l.num("min_us", if h.count > 0 { h.min_us.into() } else { 0 });
        l.num("mean_us", h.mean_us());
        l.num("max_us", h.max_us.into());
        l.num("max_at_us", h.max_at_us);
        l.num("sum_us", h.total_us);
        l.array("buckets", h.buckets.iter().enumerate(), &mut |o, (i, n)| {
            o.str("{\"below_us\":");
            match rri_firmware::engine::Histogram::bucket_limit_us(i) {
                Some(limit) => o.u32(limit),
                None => o.str("null"),
            }
            o.str(",\"count\":");
            o.u64(*n);
            o.str("}");
        });
    });
    match s.stack {
        Some(st) => m.object("stack", &mut |k| {
            k.num("boot_bytes", st.boot.into());
            k.num("running_bytes", st.running.into());
            k.num("size_bytes", st.size.into());
            k.num("margin_percent", st.margin_percent().into());
        }),
        None => m.null("stack"),
    }
    match &s.bad {
        Some(bad) => m.object("last_bad_message", &mut |b| {
            b.num("at_us", bad.at.as_micros());
            b.endpoint("from", Some(bad.from));
            b.text("error", bad.kind.name());
            b.num("offset", bad.offset.into());
            b.num("length", bad.len.into());
            b.quoted("bytes", &mut |o| o.json_bytes(bad.bytes()));
        }),
        None => m.null("last_bad_message"),
    }
    match &s.update {
        #[cfg(rri_update)]
        Some(u) => m.object("update", &mut |o| {
            o.flag("swaps", u.swaps);
            o.text("outcome", crate::update::name(&u.last));
            o.text("image", u.image.name());
            match u.previous {
                Some(v) => o.quoted("previous", &mut |w| crate::update::version(w, v)),
                None => o.null("previous"),
            }
            o.quoted("last", &mut |w| crate::update::line(w, u));
        }),
        _ => m.null("update"),
    }
    m.num("events_total", s.events.total().into());
    m.array("events", s.events.newest_first(), &mut |o, e| {
        o.str("{");
        let mut ev = Members::new(o);
        ev.num("at_us", e.at.as_micros());
        ev.text("event", view::event_name(&e.kind));
        event(&mut ev, e.kind);
        o_close(ev.out);
    });
    out.str("}\n");
}

fn o_close(o: &mut dyn Out) {
    o.str("}");
}

/// An event's own fields (the page words them for people).
#[inline(never)]
fn event(ev: &mut Members<'_>, kind: EventKind) {
    match kind {
        EventKind::Started(cause) => ev.text("cause", cause.name()),
        EventKind::State(state, error) => {
            ev.text("state", state.name());
            ev.opt_num("error_code", error.map(|e| e.code().into()));
        }
        EventKind::LinkUp(speed, duplex) => {
            ev.opt_num("speed_mbps", speed.map(u64::from));
            ev.opt_flag("full_duplex", duplex);
        }
        EventKind::Peer(p) => ev.endpoint("peer", Some(p)),
        EventKind::TimeOut | EventKind::MaxLost | EventKind::LinkDown => {}
    }
}

#[inline(never)]
fn device(d: &mut Members<'_>, id: &Identity, s: &Status) {
    d.text("name", id.device);
    d.text("type", id.device_type);
    d.text("class", id.device_class);
    d.object("firmware", &mut |f| {
        f.text("version", id.version);
        f.text("commit", id.commit);
    });
    d.text("board", id.board);
    d.object("sensor", &mut |f| {
        f.text("type", id.sensor);
        f.text("file", id.sensor_file);
    });
    match id.mac {
        Some(mac) => d.quoted("mac", &mut |o| o.mac(mac)),
        None => d.null("mac"),
    }
    d.quoted("ip", &mut |o| o.ipv4(id.ip));
    d.num("prefix_len", id.prefix.into());
    match id.gateway {
        Some(g) => d.quoted("gateway", &mut |o| o.ipv4(g)),
        None => d.null("gateway"),
    }
    d.object("link", &mut |l| {
        l.flag("up", s.link.up);
        l.opt_num("speed_mbps", s.link.speed_mbps.map(u64::from));
        l.opt_flag("full_duplex", s.link.full_duplex);
    });
    d.num("uptime_us", s.now.as_micros());
    match &s.reset {
        Some(reset) => d.object("reset", &mut |r| {
            r.text("cause", reset.cause.name());
            r.num("boots", reset.boots.into());
            r.opt_num("pc", reset.pc.map(|(pc, _)| pc.into()));
            r.opt_num("lr", reset.pc.map(|(_, lr)| lr.into()));
            match reset.panic_file() {
                Some((file, _)) => r.quoted("panic_file", &mut |o| o.json_bytes(file)),
                None => r.null("panic_file"),
            }
            r.opt_num("panic_line", reset.panic_file().map(|(_, l)| l.into()));
        }),
        None => d.null("reset"),
    }
}

#[inline(never)]
fn config(c: &mut Members<'_>, id: &Identity) {
    c.text("protocol", view::protocol(id.protocol));
    c.num("port", id.port.into());
    c.num("http_port", id.http_port.into());
    match id.config.controller {
        Some(p) => c.quoted("controller", &mut |o| view::pinned(o, p)),
        None => c.null("controller"),
    }
    c.num("timeout_ms", id.config.timeout_ms.into());
    c.num("max_lost", id.config.max_lost.into());
    c.flag("dry_run", id.config.dry_run);
    c.num("send_period_ms", id.config.send_period_ms.into());
    let mut property =
        |o: &mut dyn Out, (i, p, robot): (usize, &rri_firmware::schema::PropertyInfo, bool)| {
            o.str("{");
            let mut m = Members::new(o);
            m.text("name", p.name);
            m.text("wire", p.wire);
            m.text("type", p.ty);
            m.text(
                "direction",
                if robot {
                    "controller to device"
                } else {
                    "device to controller"
                },
            );
            if !robot {
                m.flag("reply", i == id.config.reply);
                m.num("period_ms", view::period_ms(&id.config, i).into());
            }
            m.array("fields", p.fields.iter(), &mut |o, (name, ty)| {
                o.str("{\"name\":\"");
                o.json(name);
                o.str("\",\"type\":\"");
                o.json(ty);
                o.str("\"}");
            });
            o_close(m.out);
        };
    let robot = id.received.iter().enumerate().map(|(i, p)| (i, p, true));
    let device = id.sent.iter().enumerate().map(|(i, p)| (i, p, false));
    c.array("properties", robot.chain(device), &mut property);
}

#[inline(never)]
fn counters(c: &mut Members<'_>, s: &Status, robot_properties: usize) {
    let st = &s.snapshot.stats;
    for family in FAMILIES.iter() {
        c.object(family.key, &mut |f| {
            for counter in family.members {
                f.num(counter.key, (counter.get)(st));
            }
        });
    }
    c.object("decode_errors", &mut |f| {
        for kind in DecodeErrorKind::ALL {
            f.num(kind.name(), st.decode_errors_of(kind));
        }
    });
    c.array(
        "robot_properties",
        s.snapshot.robot_seen.iter().take(robot_properties),
        &mut |o, seen| {
            o.str("{\"messages\":");
            o.u32(seen.messages);
            o.str(",\"interval_us\":");
            o.u32(seen.interval_us);
            o.str("}");
        },
    );
    match s.nic {
        Some(n) => c.object("nic", &mut |f| {
            f.num("rx_frames", n.rx_frames.into());
            f.num("rx_dropped", n.rx_dropped.into());
            f.flag("rx_dropped_at_least", n.rx_dropped_at_least);
            f.num("status_full", n.status_full.into());
            f.num("fifo_max", n.fifo_max.into());
        }),
        None => c.null("nic"),
    }
}
