//! What zenoh keeps of keys declared once and dropped: a router and a client session (in this
//! process, or the router in another), and `CYCLES` times a key `probe/<k>/...` with the
//! entities MODE names declared on it and dropped; this process's resident memory printed every
//! `EVERY` cycles. Why the daemon reuses session ids and clients give one liveliness chunk for
//! all their sessions (`docs/decisions/service.md`, "Keys a connection sees").
//!
//! `cargo run -p lumen-transport --example key_churn -- [MODE] [CYCLES] [EVERY]`
//!
//! MODE, letters: on the router's session `s` a subscriber, `p` a publisher (and a put), `l` a
//! liveliness subscriber, `t` a liveliness token, `q` a queryable; on the client's `P` a
//! publisher (and a put), `S` a subscriber, `T` a liveliness token, `G` a get, `U` a put without
//! a publisher, `c` all of P, S and T. The key: fresh each cycle, `r` one of 50 in turn, `f`
//! always the same; `x` the token's last chunk fresh each cycle. `R` alone: only a router,
//! printing its memory every 2 s (with `PROBE_PORT=<port>` set for both processes, the other
//! one's "router" entities are a second client's).

use zenoh::Wait;

fn rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc");
    status.lines().find_map(|l| l.strip_prefix("VmRSS:")).and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok()).expect("VmRSS")
}

fn main() {
    let mut args = std::env::args().skip(1);
    let mode = args.next().unwrap_or_else(|| "spltc".into());
    let cycles: usize = args.next().map_or(4000, |n| n.parse().expect("CYCLES: a number"));
    let every: usize = args.next().map_or(500, |n| n.parse().expect("EVERY: a number"));
    let external = std::env::var("PROBE_PORT").ok();
    let port = external.as_ref().map_or(17000 + (std::process::id() % 20000) as u16, |p| p.parse().expect("PROBE_PORT: a port"));
    let endpoint = vec![format!("tcp/127.0.0.1:{port}")];
    let config = match (&external, mode.as_str()) {
        (Some(_), "R") | (None, _) => lumen_transport::net::config("router", &endpoint, &[]),
        (Some(_), _) => lumen_transport::net::client_config(&endpoint),
    };
    let router = zenoh::open(config.expect("a configuration")).wait().expect("a session");
    if mode == "R" {
        loop {
            std::thread::sleep(std::time::Duration::from_secs(2));
            println!("router {}", rss_kib());
        }
    }
    let client = zenoh::open(lumen_transport::net::client_config(&endpoint).expect("a configuration")).wait().expect("a session");
    let _wild = router.declare_queryable("probe/control/**").wait().unwrap();
    let has = |c: char| mode.contains(c);
    println!("cycle, KiB");
    for k in 0..=cycles {
        if k % every == 0 {
            println!("{k}, {}", rss_kib());
        }
        let key = match (has('f'), has('r')) {
            (true, _) => "probe/0".to_string(),
            (_, true) => format!("probe/{}", k % 50),
            _ => format!("probe/{k}"),
        };
        let chunk = if has('x') { format!("x{k}") } else { "x".into() };
        let s = has('s').then(|| router.declare_subscriber(format!("{key}/frame")).wait().unwrap());
        let p = has('p').then(|| router.declare_publisher(format!("{key}/contacts")).wait().unwrap());
        let l = has('l').then(|| router.liveliness().declare_subscriber(format!("{key}/client/{chunk}")).history(true).wait().unwrap());
        let t = has('t').then(|| router.liveliness().declare_token(format!("{key}/live")).wait().unwrap());
        let q = has('q').then(|| router.declare_queryable(format!("{key}/observe")).wait().unwrap());
        let cp = (has('c') || has('P')).then(|| client.declare_publisher(format!("{key}/frame")).wait().unwrap());
        let cs = (has('c') || has('S')).then(|| client.declare_subscriber(format!("{key}/contacts")).wait().unwrap());
        let ct = (has('c') || has('T')).then(|| client.liveliness().declare_token(format!("{key}/client/{chunk}")).wait().unwrap());
        let cq = has('G').then(|| client.get(format!("{key}/observe")).wait().unwrap());
        if let Some(p) = &p {
            p.put(vec![0u8; 64]).wait().unwrap();
        }
        if let Some(cp) = &cp {
            cp.put(vec![0u8; 64]).wait().unwrap();
        }
        if has('U') {
            client.put(format!("{key}/frame"), vec![0u8; 64]).wait().unwrap();
        }
        drop((s, p, l, t, q, cp, cs, ct, cq));
    }
}
