#!/bin/bash
# Reproduces a Zenoh stall in partitions; see zenoh_partition_stall.rs. Needs root.
# usage: examples/zenoh_partition_stall.sh [peers in B, default 2]   (NOLIV=1, NOGOSSIP=1, OPEN_TIMEOUT=ms pass through)
# build first: CARGO_TARGET_DIR=${MRMM_TARGET_DIR:-$HOME/.cache/mrmm/target} cargo build --example zenoh_partition_stall
set -u
EXE=${MRMM_TARGET_DIR:-$HOME/.cache/mrmm/target}/debug/examples/zenoh_partition_stall; A=stalla; B=stallb; NB=${1:-2}
ip netns add $A; ip netns add $B; ip link add vsa netns $A type veth peer name vsb netns $B
ip -n $A addr add 10.199.0.1/24 dev vsa; ip -n $B addr add 10.199.0.2/24 dev vsb
for ns in $A $B; do ip -n $ns link set lo up; done; ip -n $A link set vsa up; ip -n $B link set vsb up
RUST_LOG=${RLOG:-} ip netns exec $A env RUST_LOG=${RLOG:-} $EXE router tcp/10.199.0.1:17447 > /tmp/st_r.txt 2>&1 & sleep 1
ip netns exec $A env RUST_LOG=${RLOG:-} $EXE peer tcp/10.199.0.1:0 tcp/10.199.0.1:17447 > /tmp/st_p1.txt 2>&1 &
for i in $(seq 1 $NB); do ip netns exec $B $EXE peer tcp/10.199.0.2:0 tcp/10.199.0.1:17447 > /tmp/st_b$i.txt 2>&1 & done
sleep 5; ip -n $A link set vsa down; sleep 16; ip -n $A link set vsa up; sleep 2
pkill -f "$EXE"; sleep 0.5; ip netns del $A; ip netns del $B
echo "worst delay at p1 after the cut: $(awk '{print $4}' /tmp/st_p1.txt | sort -n | tail -1) ms"
