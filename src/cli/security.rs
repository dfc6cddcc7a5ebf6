//! Security options every service and tool shares — `--pki DIR [--as NAME]`, or `--ca`, `--cert`
//! and `--key` — and the tool config file (`--config`, or `MRMM_TOOL_CONFIG`) that operator tools
//! (`op`, `tap`, `viz`) read: where central is and which certificate to use.

use std::path::{Path, PathBuf};

use anyhow::Context;
use mrmm_proto::SecuritySection;
use serde::Deserialize;

/// Environment variable naming a tool config file (the demo prints the line that sets it).
pub const TOOL_CONFIG_ENV: &str = "MRMM_TOOL_CONFIG";

#[derive(Debug, Clone, Default, clap::Args)]
pub struct SecurityArgs {
    /// Fleet PKI directory (made by `mrmm pki`): uses DIR/ca.crt and DIR/NAME.crt, DIR/NAME.key.
    #[arg(long, value_name = "DIR")]
    pub pki: Option<PathBuf>,
    /// The certificate of --pki to use (default: this node's name; `operator` for operator tools).
    #[arg(long = "as", id = "pki_name", value_name = "NAME", requires = "pki")]
    pub name: Option<String>,
    /// Fleet CA certificate (PEM); with --cert and --key instead of --pki.
    #[arg(long = "ca", id = "ca_file", value_name = "FILE", requires_all = ["cert_file", "key_file"], conflicts_with = "pki")]
    pub ca: Option<PathBuf>,
    /// This node's certificate (PEM).
    #[arg(long = "cert", id = "cert_file", value_name = "FILE", requires = "ca_file")]
    pub cert: Option<PathBuf>,
    /// This node's private key (PEM).
    #[arg(long = "key", id = "key_file", value_name = "FILE", requires = "ca_file")]
    pub key: Option<PathBuf>,
}

impl SecurityArgs {
    /// The security section the flags give (`default_name`: the certificate name in --pki).
    pub fn section(&self, default_name: &str) -> Option<SecuritySection> {
        if let Some(dir) = &self.pki {
            return Some(SecuritySection::from_dir(dir, self.name.as_deref().unwrap_or(default_name)));
        }
        match (&self.ca, &self.cert, &self.key) {
            (Some(ca), Some(cert), Some(key)) => {
                let mut s = SecuritySection::from_dir(Path::new("."), default_name);
                (s.ca, s.cert, s.key) = (ca.clone(), cert.clone(), key.clone());
                Some(s)
            }
            _ => None,
        }
    }
}

/// What an operator tool reads from its config file.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolConfig {
    /// Central's endpoints.
    #[serde(default)]
    pub connect: Vec<String>,
    /// The operator certificate (relative paths: relative to the file).
    #[serde(default)]
    pub security: Option<SecuritySection>,
}

impl ToolConfig {
    /// The file `path`, or the one `MRMM_TOOL_CONFIG` names, or nothing.
    pub fn load(path: Option<&Path>) -> anyhow::Result<ToolConfig> {
        let env = std::env::var_os(TOOL_CONFIG_ENV).map(PathBuf::from);
        let Some(path) = path.map(Path::to_path_buf).or(env) else { return Ok(ToolConfig::default()) };
        let mut cfg: ToolConfig = mrmm_proto::config::load_json5(&path).with_context(|| format!("tool config {}", path.display()))?;
        if let (Some(sec), Some(dir)) = (cfg.security.as_mut(), path.parent()) {
            let _ = dir;
            mrmm_peer::config::resolve_security_paths(sec, &path);
        }
        Ok(cfg)
    }

    /// The endpoints to use: the flags', else the file's, else `default`.
    pub fn connect(&self, flags: &[String], default: &str) -> Vec<String> {
        if !flags.is_empty() {
            flags.to_vec()
        } else if !self.connect.is_empty() {
            self.connect.clone()
        } else {
            vec![default.to_string()]
        }
    }

    /// The security section: the flags', else the file's.
    pub fn security(&self, flags: &SecurityArgs, default_name: &str) -> Option<SecuritySection> {
        flags.section(default_name).or_else(|| self.security.clone())
    }
}
