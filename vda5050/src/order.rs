//! The orders a master control gives one vehicle ([`OrderBook`]): a new order starts where the
//! vehicle stands; every later release is an update of the same order (same `orderId`,
//! `orderUpdateId` + 1) stitched at the last node of the base it had, with the sequence ids the
//! standard asks for (nodes even, edges odd, on from the stitching node). A base once released is
//! never changed: an update only adds to it. After a cancel, or when the vehicle reports an order
//! that is not the book's, the next release is a new order.

use crate::msg::{Edge, Header, Node, NodePosition, Order, State};

/// A point of an order: the node's id and where it is in the map's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Waypoint {
    pub node_id: String,
    pub x: f64,
    pub y: f64,
}

/// The order being driven.
#[derive(Debug, Clone, PartialEq)]
struct Current {
    order_id: String,
    update_id: u64,
    /// The last released node: where the next update is stitched.
    last_base: (Waypoint, u64),
}

/// The orders of one vehicle.
#[derive(Debug, Clone, PartialEq)]
pub struct OrderBook {
    /// Order ids are `<prefix>-<n>`: the prefix keeps them unique across the gateway's restarts.
    prefix: String,
    map_id: String,
    orders: u64,
    current: Option<Current>,
}

impl OrderBook {
    pub fn new(prefix: &str, map_id: &str) -> OrderBook {
        OrderBook { prefix: prefix.to_string(), map_id: map_id.to_string(), orders: 0, current: None }
    }

    /// The order being driven, if any.
    pub fn order_id(&self) -> Option<&str> {
        self.current.as_ref().map(|c| c.order_id.as_str())
    }

    /// The last released node and its sequence id.
    pub fn last_base(&self) -> Option<(&Waypoint, u64)> {
        self.current.as_ref().map(|c| (&c.last_base.0, c.last_base.1))
    }

    /// The order, or the update of the current one, that has the vehicle drive on through `base`
    /// (released now) towards `horizon` (not yet released), at most `speed` m/s. A new order
    /// starts at `here` (the vehicle's last node, where it stands); an update at the last node
    /// released before. The header is the sender's to fill.
    pub fn release(&mut self, here: &Waypoint, base: &[Waypoint], horizon: &[Waypoint], speed: Option<f64>) -> Order {
        let (order_id, update_id, first) = match &self.current {
            Some(c) => (c.order_id.clone(), c.update_id + 1, c.last_base.clone()),
            None => {
                self.orders += 1;
                (format!("{}-{}", self.prefix, self.orders), 0, (here.clone(), 0))
            }
        };
        let node = |w: &Waypoint, seq: u64, released: bool| Node {
            node_id: w.node_id.clone(),
            sequence_id: seq,
            released,
            node_position: Some(NodePosition { x: w.x, y: w.y, allowed_deviation_xy: None, map_id: self.map_id.clone() }),
            actions: Vec::new(),
        };
        let mut nodes = vec![node(&first.0, first.1, true)];
        let mut edges = Vec::new();
        let mut last = (first.0.clone(), first.1);
        let mut seq = first.1;
        let mut prev = first.0.node_id.clone();
        for (w, released) in base.iter().map(|w| (w, true)).chain(horizon.iter().map(|w| (w, false))) {
            edges.push(Edge {
                edge_id: format!("{prev}--{}", w.node_id),
                sequence_id: seq + 1,
                released,
                start_node_id: prev.clone(),
                end_node_id: w.node_id.clone(),
                max_speed: speed,
                actions: Vec::new(),
            });
            seq += 2;
            nodes.push(node(w, seq, released));
            if released {
                last = (w.clone(), seq);
            }
            prev.clone_from(&w.node_id);
        }
        self.current = Some(Current { order_id: order_id.clone(), update_id, last_base: last });
        Order { header: Header::default(), order_id, order_update_id: update_id, nodes, edges }
    }

    /// The order was cancelled (or the vehicle dropped it): the next release is a new order.
    pub fn forget(&mut self) {
        self.current = None;
    }

    /// Follows the vehicle's state: an order that is not one of the book's (someone else gave
    /// it one, or it restarted with another) makes the next release a new order. An earlier
    /// order of the book's is a state older than the book's last order, not news.
    pub fn observe(&mut self, state: &State) {
        let ours = state.order_id.strip_prefix(&self.prefix).is_some_and(|rest| rest.starts_with('-'));
        if self.current.is_some() && !state.order_id.is_empty() && !ours {
            self.current = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w(id: &str, x: f64) -> Waypoint {
        Waypoint { node_id: id.into(), x, y: 0.0 }
    }

    #[test]
    fn a_new_order_starts_where_the_vehicle_stands_and_numbers_nodes_even_edges_odd() {
        let mut book = OrderBook::new("gw", "office");
        let o = book.release(&w("a", 0.0), &[w("b", 1.0)], &[w("c", 2.0)], Some(0.5));
        assert_eq!((o.order_id.as_str(), o.order_update_id), ("gw-1", 0));
        let nodes: Vec<_> = o.nodes.iter().map(|n| (n.node_id.as_str(), n.sequence_id, n.released)).collect();
        assert_eq!(nodes, [("a", 0, true), ("b", 2, true), ("c", 4, false)]);
        let edges: Vec<_> = o.edges.iter().map(|e| (e.start_node_id.as_str(), e.end_node_id.as_str(), e.sequence_id, e.released)).collect();
        assert_eq!(edges, [("a", "b", 1, true), ("b", "c", 3, false)]);
        assert_eq!(o.nodes[1].node_position.as_ref().unwrap().map_id, "office");
    }

    #[test]
    fn an_update_is_stitched_at_the_last_base_node_and_keeps_its_sequence_id() {
        let mut book = OrderBook::new("gw", "m");
        book.release(&w("a", 0.0), &[w("b", 1.0)], &[w("c", 2.0)], None);
        let u = book.release(&w("ignored", 9.0), &[w("c", 2.0), w("d", 3.0)], &[], None);
        assert_eq!((u.order_id.as_str(), u.order_update_id), ("gw-1", 1));
        let nodes: Vec<_> = u.nodes.iter().map(|n| (n.node_id.as_str(), n.sequence_id, n.released)).collect();
        assert_eq!(nodes, [("b", 2, true), ("c", 4, true), ("d", 6, true)]);
        assert_eq!(book.last_base().map(|(w, s)| (w.node_id.as_str(), s)), Some(("d", 6)));
    }

    #[test]
    fn after_a_cancel_or_a_foreign_order_the_next_release_is_a_new_order() {
        let mut book = OrderBook::new("gw", "m");
        book.release(&w("a", 0.0), &[w("b", 1.0)], &[], None);
        book.forget();
        let o = book.release(&w("b", 1.0), &[w("c", 2.0)], &[], None);
        assert_eq!((o.order_id.as_str(), o.order_update_id, o.nodes[0].sequence_id), ("gw-2", 0, 0));
        let late = State { order_id: "gw-1".into(), ..State::default() };
        book.observe(&late);
        assert_eq!(book.order_id(), Some("gw-2"), "a late state of an earlier order of ours is not news");
        let foreign = State { order_id: "someone-else".into(), ..State::default() };
        book.observe(&foreign);
        assert_eq!(book.order_id(), None);
    }
}
