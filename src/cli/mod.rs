//! Command-line interface: argument parsing and dispatch, one file per subcommand.

mod assign;
mod central;
mod console;
mod demo;
mod map;
mod mission_host;
pub mod op;
mod pki;
mod plan;
mod planner_service;
mod robot;
mod router;
mod security;
mod shutdown;
mod sim_fleet;
mod table;
mod tap;
pub mod threads;
mod tour;
mod vda5050;
mod vda5050_sim;
mod viz;

use clap::{Parser, Subcommand};

/// Multiple Robots for Multiple Missions: run one robot fleet on several missions at once.
#[derive(Debug, Parser)]
#[command(name = "mrmm", version, about)]
pub struct Cli {
    /// Async worker threads of this process (default: 2 for a robot, one per core otherwise).
    /// A robot also bounds Zenoh's runtimes to 4 threads unless `ZENOH_RUNTIME` is set.
    #[arg(long, global = true, env = "MRMM_THREADS")]
    threads: Option<std::num::NonZeroUsize>,
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Run the central node: a Zenoh router hosting the system manager.
    Central(central::Args),
    /// Run one robot peer (simulated body) from a config file.
    Robot(robot::Args),
    /// Run many simulated robots in one process (each its own identity and session); crash and
    /// start them one by one from stdin (`kill ID…`, `start ID…`, `list`) or SIGUSR1.
    SimFleet(sim_fleet::Args),
    /// Run the VDA 5050 gateway: every vehicle on an MQTT broker joins the fleet as a robot.
    #[command(name = "vda5050")]
    Vda5050(vda5050::Args),
    /// Run simulated VDA 5050 vehicles, on an MQTT broker of their own unless one is given.
    #[command(name = "vda5050-sim")]
    Vda5050Sim(vda5050_sim::Args),
    /// Run a site router of a multi-site fleet (robots of the site are its peers).
    Router(router::Args),
    /// Operator commands against a running fleet.
    Op(op::Args),
    /// Start central and a simulated fleet, drive it, and show it live.
    Demo(demo::Args),
    /// The paper's evaluation on the real system: messages, idleness, environment (figures,
    /// results.csv, summary.md).
    Experiment(mrmm_experiments::Args),
    /// Near-optimal closed tour through a TSPLIB instance.
    Tour(tour::Args),
    /// Optimal assignment from a CSV cost matrix (rows: robots, columns: slots).
    Assign(assign::Args),
    /// Plan a recipe for a set of robots; prints the per-robot plans as JSON.
    Plan(plan::Args),
    /// Maps: `map check FILE` reads one as the fleet would.
    Map(map::Args),
    /// Run planner services (`mrmm/planner/<kind>`) in their own process.
    PlannerService(planner_service::Args),
    /// Run a mission host (mission managers) in its own process.
    MissionHost(mission_host::Args),
    /// Live fleet view in Rerun: a viewer, a spawned viewer, or an .rrd file.
    Viz(viz::Args),
    /// The browser console: the fleet on a map; select robots and assign them to missions.
    Console(console::Args),
    /// Print what is published on a key expression, as JSON lines.
    Tap(tap::Args),
    /// The fleet's certificates: `pki init DIR`, `pki issue DIR --role R --id NAME`.
    Pki(pki::Args),
}

impl Cli {
    /// The threads this process starts (`--threads`, and its role).
    pub fn threads(&self) -> threads::Threads {
        threads::Threads::new(matches!(self.command, Cmd::Robot(_)), self.threads)
    }

    /// Log filter used when RUST_LOG is not set. Zenoh warns at every secure link that it skips
    /// the server's name check: the fleet's own choice (its certificates name identities, not
    /// addresses; `verify_names` turns the check on), not something wrong — so not logged.
    pub fn default_log_filter(&self) -> &'static str {
        match self.command {
            Cmd::Op(_)
            | Cmd::Console(_)
            | Cmd::Demo(_)
            | Cmd::Experiment(_)
            | Cmd::Viz(_)
            | Cmd::Tour(_)
            | Cmd::Assign(_)
            | Cmd::Plan(_)
            | Cmd::Map(_)
            | Cmd::Tap(_)
            | Cmd::Pki(_) => "warn,zenoh_link_commons::quic::utils=error,zenoh_link_tls::utils=error",
            // The embedded broker says every connection and subscription at info.
            Cmd::Vda5050Sim(_) => "info,rumqttd=warn",
            _ => "info,zenoh=warn,zenoh_link_commons::quic::utils=error,zenoh_link_tls::utils=error",
        }
    }
}

pub async fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Cmd::Central(a) => central::run(a).await,
        Cmd::Robot(a) => robot::run(a).await,
        Cmd::SimFleet(a) => sim_fleet::run(a).await,
        Cmd::Vda5050(a) => vda5050::run(a).await,
        Cmd::Vda5050Sim(a) => vda5050_sim::run(a).await,
        Cmd::Router(a) => router::run(a).await,
        Cmd::Op(a) => op::run(a).await,
        Cmd::Console(a) => console::run(a).await,
        Cmd::Demo(a) => demo::run(a).await,
        Cmd::Experiment(a) => mrmm_experiments::run(a).await,
        Cmd::Tour(a) => tour::run(a),
        Cmd::Assign(a) => assign::run(a),
        Cmd::Plan(a) => plan::run(a),
        Cmd::Map(a) => map::run(a),
        Cmd::PlannerService(a) => planner_service::run(a).await,
        Cmd::MissionHost(a) => mission_host::run(a).await,
        Cmd::Viz(a) => viz::run(a).await,
        Cmd::Tap(a) => tap::run(a).await,
        Cmd::Pki(a) => pki::run(a),
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    #[test]
    fn every_subcommand_parses_its_flags() {
        // clap's own consistency checks (unique names, valid requirements) for every subcommand.
        super::Cli::command().debug_assert();
    }
}
