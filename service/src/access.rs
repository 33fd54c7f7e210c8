//! Who may do what over zenoh when the daemon requires client certificates (mutual TLS): the
//! grants per certificate common name, the zenoh access-control rules that enforce them on
//! every message, and the requester of a control request.
//!
//! zenoh's ACL sees key expressions, not payloads, so it enforces *which keys* a certificate
//! may use: a client may query only `lumen/control/<its common name>` (and the bare
//! `lumen/control`, answered with an error saying so), put frames and declare its liveliness
//! token only if it may open, subscribe to the observer keys only if it may observe, and no
//! client may declare a queryable or send a reply (no impostor daemon) or put on a contacts or
//! observer key (no forged replies). Two checks are ours, because they are inside the payload
//! or need a count, which an ACL rule cannot express: the operation a control request asks for,
//! and the number of sessions a certificate holds.

use lumen_transport::names::{self, CONTROL, DAEMONS_ALIVE};
use serde::{Deserialize, Serialize};
use serde_json::json;

/// What the holder of one client certificate may do.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grant {
    /// The certificate's subject common name (one zenoh key chunk: no `/ * $ # ?`).
    pub name: String,
    /// Sessions it may hold open at once (0: it may not open).
    #[serde(default)]
    pub open: usize,
    /// Whether it may observe sessions (`describe` and the observer keys of any session).
    #[serde(default)]
    pub observe: bool,
    /// Whether it may query `status`.
    #[serde(default)]
    pub status: bool,
}

impl Grant {
    /// What every certified client may do when the configuration names none.
    fn everything(max_sessions: usize) -> Self {
        Self { name: "*".into(), open: max_sessions, observe: true, status: true }
    }
}

/// The daemon's policy for certified zenoh clients, checked once at start.
#[derive(Debug, Clone, PartialEq)]
pub struct Policy {
    /// Named certificates; empty: every certificate the CA signed may do everything.
    grants: Vec<Grant>,
    max_sessions: usize,
}

/// Who sent a control request, as far as the transport can tell.
#[derive(Debug, Clone, PartialEq)]
pub enum Requester {
    /// iceoryx2, or zenoh without client certificates: anyone who can reach the daemon.
    Anyone,
    /// A zenoh client whose certificate has this grant (zenoh's ACL let it use its own key).
    Certified(Grant),
    /// A certified zenoh client that sent its request on the bare `lumen/control`.
    Unnamed,
}

/// A policy that cannot be used.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PolicyError {
    #[error("access name {0:?}: a certificate common name used as one zenoh key chunk must be non-empty and free of '/', '*', '$', '#', '?'")]
    BadName(String),
    #[error("access name {0:?} is listed twice")]
    Duplicate(String),
}

impl Policy {
    /// Checks the grants: names usable as key chunks, each named once.
    pub fn new(grants: Vec<Grant>, max_sessions: usize) -> Result<Self, PolicyError> {
        for (i, g) in grants.iter().enumerate() {
            if !names::is_key_chunk(&g.name) {
                return Err(PolicyError::BadName(g.name.clone()));
            }
            if grants[..i].iter().any(|h| h.name == g.name) {
                return Err(PolicyError::Duplicate(g.name.clone()));
            }
        }
        Ok(Self { grants, max_sessions })
    }

    /// The requester of a query on `key` (`lumen/control` or `lumen/control/<name>`).
    pub fn requester(&self, key: &str) -> Requester {
        let Some(name) = key.strip_prefix(CONTROL).and_then(|rest| rest.strip_prefix('/')) else { return Requester::Unnamed };
        if self.grants.is_empty() {
            return Requester::Certified(Grant { name: name.to_owned(), ..Grant::everything(self.max_sessions) });
        }
        match self.grants.iter().find(|g| g.name == name) {
            Some(g) => Requester::Certified(g.clone()),
            // zenoh's ACL lets no unnamed certificate query a named key; refuse all the same.
            None => Requester::Certified(Grant { name: name.to_owned(), open: 0, observe: false, status: false }),
        }
    }

    /// The zenoh `access_control` configuration (JSON) enforcing the key rules above.
    pub fn acl(&self) -> serde_json::Value {
        let grants = if self.grants.is_empty() { vec![Grant::everything(self.max_sessions)] } else { self.grants.clone() };
        let session = |leaf: &str| format!("{}/session/*/{leaf}", names::ROOT);
        let rule = |id: String, messages: &[&str], flow: &str, keys: Vec<String>| json!({ "id": id, "messages": messages, "flows": [flow], "permission": "allow", "key_exprs": keys });
        // Every certified client: the bare control key (answered with an error naming its own
        // key) and watching the daemon's liveliness.
        let mut rules = vec![
            rule("control-bare-in".into(), &["query"], "ingress", vec![CONTROL.into()]),
            rule("control-bare-out".into(), &["reply", "declare_queryable"], "egress", vec![CONTROL.into()]),
            rule("daemon-watch-in".into(), &["declare_liveliness_subscriber", "liveliness_query"], "ingress", vec![DAEMONS_ALIVE.into()]),
            rule("daemon-watch-out".into(), &["liveliness_token", "reply"], "egress", vec![DAEMONS_ALIVE.into()]),
            // Opening: frames in, replies out, the client's liveliness token in.
            rule("open-in".into(), &["put"], "ingress", vec![session("frame")]),
            rule("open-sub".into(), &["declare_subscriber"], "ingress", vec![session("contacts")]),
            rule("open-token".into(), &["liveliness_token"], "ingress", vec![session("client/*")]),
            rule("open-out".into(), &["put"], "egress", vec![session("contacts")]),
            // The daemon's frame subscriber, announced so the client's publisher sends to it.
            rule("open-decl-out".into(), &["declare_subscriber"], "egress", vec![session("frame")]),
            // Observing: asks in, their answers out (the daemon's queryable announced), watching
            // the daemon's token for the session.
            rule("observe-in".into(), &["query"], "ingress", vec![session("observe")]),
            rule("observe-watch-in".into(), &["declare_liveliness_subscriber", "liveliness_query"], "ingress", vec![session("live")]),
            rule("observe-out".into(), &["reply", "declare_queryable"], "egress", vec![session("observe")]),
            rule("observe-watch-out".into(), &["liveliness_token", "reply"], "egress", vec![session("live")]),
        ];
        let mut subjects = Vec::new();
        let mut policies = Vec::new();
        for (i, g) in grants.iter().enumerate() {
            let key = if g.name == "*" { format!("{CONTROL}/*") } else { names::control_name_for(&g.name) };
            rules.push(rule(format!("control-{i}-in"), &["query"], "ingress", vec![key.clone()]));
            rules.push(rule(format!("control-{i}-out"), &["reply", "declare_queryable"], "egress", vec![key]));
            // A subject without common names matches every certificate.
            subjects.push(if g.name == "*" { json!({ "id": format!("client-{i}") }) } else { json!({ "id": format!("client-{i}"), "cert_common_names": [g.name] }) });
            let mut allowed = vec![format!("control-{i}-in"), format!("control-{i}-out"), "control-bare-in".into(), "control-bare-out".into(), "daemon-watch-in".into(), "daemon-watch-out".into()];
            if g.open > 0 {
                allowed.extend(["open-in", "open-sub", "open-token", "open-out", "open-decl-out"].map(String::from));
            }
            if g.observe {
                allowed.extend(["observe-in", "observe-watch-in", "observe-out", "observe-watch-out"].map(String::from));
            }
            policies.push(json!({ "id": format!("policy-{i}"), "rules": allowed, "subjects": [format!("client-{i}")] }));
        }
        json!({ "enabled": true, "default_permission": "deny", "rules": rules, "subjects": subjects, "policies": policies })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grant(name: &str, open: usize, observe: bool, status: bool) -> Grant {
        Grant { name: name.into(), open, observe, status }
    }

    #[test]
    fn names_that_are_not_one_key_chunk_or_repeat_are_refused() {
        for bad in ["", "a/b", "a*", "$x", "#", "a?"] {
            assert_eq!(Policy::new(vec![grant(bad, 1, true, true)], 4), Err(PolicyError::BadName(bad.into())));
        }
        assert_eq!(Policy::new(vec![grant("a", 1, true, true), grant("a", 0, false, false)], 4), Err(PolicyError::Duplicate("a".into())));
    }

    #[test]
    fn the_key_names_the_requester_and_its_grant() {
        let p = Policy::new(vec![grant("physics", 2, false, false), grant("tutor", 0, true, true)], 16).unwrap();
        assert_eq!(p.requester("lumen/control/physics"), Requester::Certified(grant("physics", 2, false, false)));
        assert_eq!(p.requester("lumen/control/stranger"), Requester::Certified(grant("stranger", 0, false, false)));
        assert_eq!(p.requester("lumen/control"), Requester::Unnamed);
        let open = Policy::new(vec![], 16).unwrap();
        assert_eq!(open.requester("lumen/control/anyone"), Requester::Certified(grant("anyone", 16, true, true)));
    }

    #[test]
    fn the_acl_gives_each_name_its_control_key_and_only_its_rights() {
        let p = Policy::new(vec![grant("physics", 2, false, false), grant("tutor", 0, true, true)], 16).unwrap();
        let acl = p.acl();
        assert_eq!(acl["default_permission"], "deny");
        let rules = |i: usize| acl["policies"][i]["rules"].as_array().unwrap().iter().map(|r| r.as_str().unwrap().to_owned()).collect::<Vec<_>>();
        assert!(rules(0).contains(&"open-in".into()) && !rules(0).contains(&"observe-in".into()));
        assert!(!rules(1).contains(&"open-in".into()) && rules(1).contains(&"observe-in".into()));
        assert_eq!(acl["subjects"][1]["cert_common_names"][0], "tutor");
        let key = |id: &str| acl["rules"].as_array().unwrap().iter().find(|r| r["id"] == id).unwrap()["key_exprs"][0].clone();
        assert_eq!(key("control-0-in"), "lumen/control/physics");
        assert_eq!(key("control-1-out"), "lumen/control/tutor");
        // No rule lets any client declare a queryable, reply, or put on a contacts key.
        for r in acl["rules"].as_array().unwrap() {
            let m: Vec<&str> = r["messages"].as_array().unwrap().iter().map(|m| m.as_str().unwrap()).collect();
            let ingress = r["flows"][0] == "ingress";
            assert!(!(ingress && m.contains(&"declare_queryable")), "{r}");
            assert!(!(ingress && m.contains(&"reply")), "{r}");
            assert!(!(ingress && m.contains(&"put") && r["key_exprs"][0] != "lumen/session/*/frame"), "{r}");
        }
    }
}
