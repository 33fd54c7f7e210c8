//! `lumen certs`: a lab's certificate authority and the certificates its daemons and clients
//! present, as PEM files, for zenoh's mutual TLS (`lumen serve --zenoh-client-ca`).
//!
//! The first run in a folder makes the CA (`ca.pem`, `ca.key`); later runs in the same folder
//! sign new certificates with it, so a lab adds a client without touching the others. A
//! client's certificate carries its name as the subject common name: the name the daemon's
//! `[[zenoh.access]]` grants rights to, and its control key's last chunk. Written with rcgen
//! (already in the tree for zenoh's TLS), so no `openssl` is needed.

use super::{CliError, CliResult};
use clap::Args;
use rcgen::{BasicConstraints, CertificateParams, DistinguishedName, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair, KeyUsagePurpose};
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct CertsArgs {
    /// Folder of the CA and the certificates (made if missing).
    #[arg(long, default_value = "lumen-certs")]
    pub out: PathBuf,
    /// A daemon's certificate for these host names or IP addresses (repeatable): the names
    /// clients connect to (`tls/HOST:PORT`). Written as `server.pem` and `server.key`, or
    /// `<--server-file>.pem/.key`.
    #[arg(long = "server", value_name = "HOST")]
    pub servers: Vec<String>,
    /// File name (without extension) of the daemon's certificate.
    #[arg(long, default_value = "server")]
    pub server_file: String,
    /// A client certificate with this common name (repeatable): `NAME.pem` and `NAME.key`.
    #[arg(long = "client", value_name = "NAME")]
    pub clients: Vec<String>,
}

pub fn run(args: CertsArgs) -> CliResult {
    if args.servers.is_empty() && args.clients.is_empty() && args.out.join("ca.pem").exists() {
        return Err(CliError::bad_flag("--server / --client", "none", "a certificate to make (the CA exists already)"));
    }
    for name in &args.clients {
        if !lumen_transport::names::is_key_chunk(name) || name == "server" || name == "ca" {
            return Err(CliError::bad_flag("--client", name, "a name that is one zenoh key chunk (no '/', '*', '$', '#', '?'), not \"ca\" or \"server\""));
        }
    }
    std::fs::create_dir_all(&args.out).map_err(|source| CliError::FlagPath { flag: "--out", path: args.out.clone(), source })?;
    let issuer = ca(&args.out)?;
    if !args.servers.is_empty() {
        let cert = leaf(&issuer, args.servers.clone(), "lumen daemon", ExtendedKeyUsagePurpose::ServerAuth)?;
        write_pair(&args.out, &args.server_file, cert)?;
    }
    for name in &args.clients {
        // A client is known by its common name; `localhost` keeps the certificate usable where
        // a name is checked.
        let cert = leaf(&issuer, vec!["localhost".into()], name, ExtendedKeyUsagePurpose::ClientAuth)?;
        write_pair(&args.out, name, cert)?;
    }
    Ok(())
}

/// The folder's CA: read from `ca.pem` and `ca.key`, or made and written there.
fn ca(dir: &Path) -> CliResult<Issuer<'static, KeyPair>> {
    let (cert, key) = (dir.join("ca.pem"), dir.join("ca.key"));
    if cert.exists() && key.exists() {
        let read = |p: &Path| std::fs::read_to_string(p).map_err(|source| CliError::Write { path: p.to_owned(), source });
        let bad = |p: &Path, e: rcgen::Error| CliError::Write { path: p.to_owned(), source: std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()) };
        let signing = KeyPair::from_pem(&read(&key)?).map_err(|e| bad(&key, e))?;
        let issuer = Issuer::from_ca_cert_pem(&read(&cert)?, signing).map_err(|e| bad(&cert, e))?;
        eprintln!("lumen certs: signing with the CA of {}", cert.display());
        return Ok(issuer);
    }
    let signing = KeyPair::generate().map_err(rcgen_error)?;
    let mut params = CertificateParams::new(Vec::<String>::new()).map_err(rcgen_error)?;
    params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    params.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign, KeyUsagePurpose::DigitalSignature];
    params.distinguished_name = DistinguishedName::new();
    params.distinguished_name.push(DnType::CommonName, "lumen lab CA");
    let made = params.self_signed(&signing).map_err(rcgen_error)?;
    write(&cert, &made.pem(), false)?;
    write(&key, &signing.serialize_pem(), true)?;
    eprintln!("lumen certs: made a CA: {} (give it to daemons and clients) and {} (keep it private)", cert.display(), key.display());
    Ok(Issuer::new(params, signing))
}

/// A certificate for `names` with common name `cn`, for `usage`, signed by `issuer`.
fn leaf(issuer: &Issuer<'static, KeyPair>, names: Vec<String>, cn: &str, usage: ExtendedKeyUsagePurpose) -> CliResult<(String, String)> {
    let key = KeyPair::generate().map_err(rcgen_error)?;
    let mut params = CertificateParams::new(names).map_err(rcgen_error)?;
    params.distinguished_name = DistinguishedName::new();
    params.distinguished_name.push(DnType::CommonName, cn);
    params.extended_key_usages = vec![usage];
    let cert = params.signed_by(&key, issuer).map_err(rcgen_error)?;
    Ok((cert.pem(), key.serialize_pem()))
}

/// Writes `NAME.pem` and `NAME.key` (the key readable by its owner only); refuses to replace
/// either.
fn write_pair(dir: &Path, name: &str, (cert, key): (String, String)) -> CliResult {
    let (cert_path, key_path) = (dir.join(format!("{name}.pem")), dir.join(format!("{name}.key")));
    for p in [&cert_path, &key_path] {
        if p.exists() {
            return Err(CliError::Write { path: p.clone(), source: std::io::Error::new(std::io::ErrorKind::AlreadyExists, "exists already: remove it to make it again") });
        }
    }
    write(&cert_path, &cert, false)?;
    write(&key_path, &key, true)?;
    println!("{} {}", cert_path.display(), key_path.display());
    Ok(())
}

fn write(path: &Path, text: &str, private: bool) -> CliResult {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    let mode = if private { 0o600 } else { 0o644 };
    let mut f = std::fs::OpenOptions::new().write(true).create_new(true).mode(mode).open(path).map_err(|source| CliError::Write { path: path.to_owned(), source })?;
    f.write_all(text.as_bytes()).map_err(|source| CliError::Write { path: path.to_owned(), source })
}

fn rcgen_error(e: rcgen::Error) -> CliError {
    CliError::Write { path: PathBuf::from("(certificate)"), source: std::io::Error::other(e.to_string()) }
}
