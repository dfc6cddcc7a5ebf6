//! A VDA 5050 vehicle's link between its robot and the gateway that runs it: the vehicle's states
//! and visualization in, its orders and instant actions out, both bounded (a state is superseded by the next; an
//! order the gateway cannot take now is dropped and said, and the body gives it again when the
//! vehicle reports it does not have it).

use mrmm_core::body::vda::VdaOut;
use mrmm_vda5050::FromVehicle;
use tokio::sync::mpsc;

/// The robot's end of the link.
pub struct VdaLink {
    pub states: mpsc::Receiver<Box<FromVehicle>>,
    pub out: mpsc::Sender<VdaOut>,
}

impl VdaLink {
    /// Hands the gateway a message for the vehicle.
    pub(super) fn send(&self, robot: &str, out: VdaOut) {
        if let Err(e) = self.out.try_send(out) {
            tracing::warn!(robot, "VDA 5050: a message for the vehicle dropped: {e}");
        }
    }
}

/// The vehicle's next state; pending without a link (or once the gateway let go of it).
pub(super) async fn recv(link: &mut Option<VdaLink>) -> Box<FromVehicle> {
    match link {
        Some(l) => match l.states.recv().await {
            Some(s) => s,
            None => std::future::pending().await,
        },
        None => std::future::pending().await,
    }
}
