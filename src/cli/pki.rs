//! `mrmm pki`: the fleet PKI in two commands — `init DIR` makes the CA, `issue DIR --role R --id
//! NAME` a node's certificate and key (see `mrmm_net::security::pki`).

use std::path::PathBuf;

use mrmm_net::security::pki;
use mrmm_proto::Role;

#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(Debug, clap::Subcommand)]
enum What {
    /// Make the fleet CA: DIR/ca.crt (give it to every node) and DIR/ca.key (keep it safe).
    Init { dir: PathBuf },
    /// Issue a node's certificate and key, signed by the CA of DIR: DIR/NAME.crt and DIR/NAME.key.
    Issue {
        dir: PathBuf,
        /// operator | central | robot | host | planner | router
        #[arg(long)]
        role: String,
        /// The node's id (a robot's id, a mission host's name, an operator's name; `central`).
        #[arg(long)]
        id: String,
        /// An address or host name the node is reached at (repeatable; needed with verify_names).
        #[arg(long)]
        san: Vec<String>,
        /// Days the certificate is valid.
        #[arg(long, default_value_t = pki::NODE_DAYS)]
        days: u32,
    },
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.what {
        What::Init { dir } => {
            let (crt, key) = pki::init(&dir)?;
            println!("fleet CA: {} (give it to every node), {} (keep it off the fleet)", crt.display(), key.display());
        }
        What::Issue { dir, role, id, san, days } => {
            let r = Role::parse(&role).ok_or_else(|| anyhow::anyhow!("--role: {role:?} is not one of operator, central, robot, host, planner, router"))?;
            let (crt, key) = pki::issue(&dir, r, &id, &san, days)?;
            println!("{r}:{id}: {} and {} (with {}/ca.crt, in the node's `security` section)", crt.display(), key.display(), dir.display());
        }
    }
    Ok(())
}
