//! `lumen status`: the daemon's sessions as a table (or JSON).

use super::transport::TransportArgs;
use super::CliResult;
use clap::Args;
use lumen_client::StatusReport;
use lumen_proto::session::ControlReply;

#[derive(Debug, Args)]
pub struct StatusArgs {
    #[command(flatten)]
    pub transport: TransportArgs,
    /// Print the daemon's raw JSON reply, `{"reply":"status",...}` (an array of them where
    /// several daemons answer).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: StatusArgs) -> CliResult {
    let client = args.transport.client("lumen status")?;
    // Over zenoh every daemon on the network answers (through a router), each its own table.
    let reports = client.status_all()?;
    if args.json {
        // Each report as the daemon's reply carries it, `"reply":"status"` included.
        let replies: Vec<ControlReply> = reports.into_iter().map(ControlReply::Status).collect();
        match replies.as_slice() {
            [one] => println!("{}", serde_json::to_string_pretty(one)?),
            many => println!("{}", serde_json::to_string_pretty(many)?),
        }
    } else {
        for r in &reports {
            print!("{}", table(r));
        }
    }
    Ok(())
}

/// The report as a text table.
pub fn table(r: &StatusReport) -> String {
    let mut s = format!("lumen daemon {:?} pid {} (v{}), up {:.0} s, {} sessions\n", r.daemon, r.pid, r.version, r.uptime_s, r.sessions.len() + r.hidden as usize);
    if r.hidden > 0 {
        s += &format!("  {} session(s) not listed to this client (the daemon's [zenoh] status policy: counts)\n", r.hidden);
    }
    if r.sessions.is_empty() {
        return s;
    }
    s += &format!(
        "{:>18} {:<9} {:<14} {:>8} {:>6} {:>7} {:>8} {:>8} {:>8} {:>9} {:>9} {:>9}\n",
        "session", "transport", "client", "frames", "bad", "skipped", "fps", "det p50", "det p99", "svc p50", "svc p99", "contacts"
    );
    for x in &r.sessions {
        s += &format!(
            "{:>18} {:<9} {:<14} {:>8} {:>6} {:>7} {:>8.1} {:>6.0}us {:>6.0}us {:>7.0}us {:>7.0}us {:>9}\n",
            x.session,
            x.transport.to_string(),
            x.client.chars().take(14).collect::<String>(),
            x.frames,
            x.bad_frames,
            x.skipped,
            x.fps,
            x.detect.p50_us,
            x.detect.p99_us,
            x.service.p50_us,
            x.service.p99_us,
            x.contacts_last
        );
    }
    s
}
