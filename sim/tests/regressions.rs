//! Every seed that ever found a bug, kept as a named case: each runs under every simulation
//! (chain, barriers with and without teams, membership, whole system) with every invariant
//! checked after every event, and must do something there (events, messages sent). The bugs each
//! found are in the changelog's history and `git log` (`seed N`).

use mrmm_sim::{run, Config};

/// A simulation: its name and its configuration for a seed.
type Sim = (&'static str, fn(u64) -> Config);

fn replay(seed: u64) {
    let sims: [Sim; 5] = [
        ("chain", Config::chain),
        ("barrier", Config::barriers),
        ("team barrier", Config::team_barriers),
        ("membership", Config::membership),
        ("system", Config::system),
    ];
    for (what, config) in sims {
        match run(config(seed), false) {
            Ok(r) => assert!(r.events > 0 && r.sent > 0, "{what} seed {seed}: the world did nothing"),
            Err(v) => panic!("{what}: {v}; replay with MRMM_SIM_SEED={seed} cargo test -p mrmm-sim --test {}_sim -- --nocapture", what.replace(' ', "_")),
        }
    }
}

macro_rules! seeds {
    ($($name:ident = $seed:literal: $why:literal;)*) => {$(
        #[doc = $why]
        #[test]
        fn $name() {
            replay($seed);
        }
    )*};
}

seeds! {
    seed_0 = 0: "chain: a replica's state parsed from a chain message's JSON differed from the head's by a float's last bit (serde_json without `float_roundtrip`)";
    seed_1 = 1: "system (with hand-overs): a carried-on leader announced, under the new epoch, a release it knew from the old one before the newcomer arrived there";
    seed_18 = 18: "chain: catches a head elected without Raft's up-to-date rule (when `Replica::on_vote` drops it); membership: catches a robot shown lost for good when central missed its token's return (without central's roll call)";
    seed_44 = 44: "system: catches a member left on an old epoch when an unacknowledged plan is never re-sent";
    seed_159 = 159: "system: kept from the issue's list of seeds that found bugs";
    seed_166 = 166: "system: kept from the issue's list of seeds that found bugs";
    seed_176 = 176: "system (with hand-overs): a lost member replaced stayed among the mission's lost, came back into it and was in two missions";
    seed_375 = 375: "system: a robot moved out of a mission whose start was never answered joined a third mission";
    seed_890 = 890: "system: a release waiting for another mission's control held up unrelated robots";
    seed_1473 = 1473: "system: an old head told of a higher promise re-elected itself into the new lineage's epochs with the old state";
    seed_1482 = 1482: "system: a replan whose planner service did not answer was given up during a heal";
    seed_1948 = 1948: "system (simulation delivering by subscriptions): a straggler of a mission central ended, refused as no longer entitled, never heard the end and stood again with its old team";
    seed_2952 = 2952: "system: a restarted central started a journal mission anew while a cut-off replica lived";
    seed_3150 = 3150: "system: robots a head had to let go after central's restart were not held";
    seed_3245 = 3245: "system: without central's fence two heads remained after healing";
    seed_3516 = 3516: "system: a robot moved out of a mission whose new mission never started was not held";
    seed_3928 = 3928: "system: members re-admitted named the old head when a mission's manager moved";
    seed_6551 = 6551: "system: a robot being let go when central died was put into a new mission beside its old one";
    seed_6579 = 6579: "system: invariant 3 counted a replaced lineage's team";
    seed_7682 = 7682: "system: a two-node chain stalled after central restarted without its chain state";
    seed_7743 = 7743: "system: central forgot a release it still owed after a restart";
    seed_926 = 926: "membership: central, seeing a head gone that was alive, reported itself head of a chain without it; the head won the next chain epoch and every report of it was refused";
    seed_843 = 843: "membership: a mission head that missed a member's return never took it back (found without the mission host's roll call, before roll calls waited for a quiet second)";
    seed_1389 = 1389: "barrier: two robots, the leader crashed while the network lost every (backed-off) re-publication of the other's arrival — no message delivered, barriers passed alone; the harness took it for a world that did nothing";
}
