//! Subscriptions kept in step with what a machine listens to: each [`Sub`] its machine names is
//! declared once, and dropped when the machine no longer names it.

use std::collections::HashMap;
use std::sync::Arc;

use mrmm_proto::matching::Sub;
use zenoh::pubsub::Subscriber;
use zenoh::sample::{Locality, Sample};
use zenoh::Session;

/// A machine's subscriptions, by key expression, all delivering to one callback.
pub struct Following {
    session: Session,
    subs: HashMap<String, Subscriber<()>>,
    deliver: Arc<dyn Fn(Sample) + Send + Sync>,
}

impl Following {
    /// Subscriptions on `session` whose samples go to `deliver`.
    pub fn new(session: Session, deliver: impl Fn(Sample) + Send + Sync + 'static) -> Following {
        Following { session, subs: HashMap::new(), deliver: Arc::new(deliver) }
    }

    /// Subscribes to `wanted`, and only to it. One that cannot be declared is logged and tried
    /// again on the next call.
    pub async fn follow(&mut self, wanted: &[Sub]) {
        if wanted.len() == self.subs.len() && wanted.iter().all(|s| self.subs.contains_key(&s.expr)) {
            return;
        }
        self.subs.retain(|expr, _| wanted.iter().any(|s| s.expr == *expr));
        for sub in wanted {
            if self.subs.contains_key(&sub.expr) {
                continue;
            }
            let deliver = self.deliver.clone();
            let origin = if sub.remote_only { Locality::Remote } else { Locality::Any };
            match self.session.declare_subscriber(sub.expr.clone()).allowed_origin(origin).callback(move |s| deliver(s)).await {
                Ok(s) => {
                    self.subs.insert(sub.expr.clone(), s);
                }
                Err(e) => tracing::warn!("cannot subscribe to {}: {e}", sub.expr),
            }
        }
    }
}
