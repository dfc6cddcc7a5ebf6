// Virtual AGVs that nobody here wrote: vda-5050-lib's AgvController with its VirtualAgvAdapter
// (Siemens, MIT), on an MQTT broker, speaking VDA 5050 2.0. tests/vda5050.rs starts this.
//
//   node agvs.js BROKER_PORT MAP_ID MANUFACTURER SERIAL:X:Y:NODE [SERIAL:X:Y:NODE …]
//
// Prints one JSON line per AGV whenever its lastNodeId, driving, paused, orderId, errors or the
// nodes it has yet to pass change ({"serial", "lastNodeId", "driving", "paused", "orderId",
// "orderUpdateId", "base", "horizon", "x", "y", "errors"}; base and horizon: the released and the
// unreleased nodes of its nodeStates),
// and "agvs ready" once every AGV is started.
const { AgvController, VirtualAgvAdapter } = require("vda-5050-lib");

async function main() {
    const [port, mapId, manufacturer, ...specs] = process.argv.slice(2);
    const agvs = [];
    for (const spec of specs) {
        const [serial, x, y, node] = spec.split(":");
        const controller = new AgvController(
            { manufacturer, serialNumber: serial },
            { interfaceName: "uagv", transport: { brokerUrl: `mqtt://127.0.0.1:${port}`, heartbeat: 2 }, vdaVersion: "2.0.0" },
            { agvAdapterType: VirtualAgvAdapter, publishStateInterval: 2000, publishVisualizationInterval: 200 },
            { initialPosition: { mapId, x: Number(x), y: Number(y), theta: 0, lastNodeId: node }, vehicleSpeed: 1.0 },
        );
        await controller.start();
        agvs.push({ serial, controller, last: "" });
    }
    console.log("agvs ready");
    setInterval(() => {
        for (const a of agvs) {
            const s = a.controller.currentState;
            const p = s.agvPosition || {};
            const line = {
                serial: a.serial, lastNodeId: s.lastNodeId, driving: s.driving, paused: s.paused,
                orderId: s.orderId, orderUpdateId: s.orderUpdateId,
                base: (s.nodeStates || []).filter(n => n.released).length,
                horizon: (s.nodeStates || []).filter(n => !n.released).length,
                errors: (s.errors || []).map(e => `${e.errorType}: ${e.errorDescription || ""}`),
            };
            const key = JSON.stringify(line);
            if (key !== a.last) {
                a.last = key;
                console.log(JSON.stringify({ ...line, x: p.x, y: p.y }));
            }
        }
    }, 50);
}

main().catch(e => { console.error(e); process.exit(1); });
