// One OPC UA session of node-opcua's client, driven by a scenario (JSON, argv[2]):
//   {"endpoint": "opc.tcp://...", "policy": "None" | "Basic256Sha256" | "Aes256Sha256RsaPss",
//    "mode": "None" | "Sign" | "SignAndEncrypt", "user": "...", "password": "...",
//    "pki": "<a folder for the client's certificate>", "steps": [...]}
// Steps: {"op": "browse", "node"}, {"op": "read", "node"}, {"op": "call", "object",
// "method", "args": [["Double", 5], ["String", "user"]]}, {"op": "monitor", "name", "node"},
// {"op": "await", "name", "value" | "status", "timeout", "latest"?} (until the item reports
// `value`, or a value of status `status`; with "latest": until its latest report is that),
// {"op": "parallel", "steps": [...]} (sent at once; the order their answers came in).
// Prints one JSON object: {"connected", "error"?, "results": [...]} (a result per step).
// An array of scenarios runs them one after the other (one process: node-opcua loads once)
// and prints an array of those objects.
import {
  AttributeIds,
  ClientMonitoredItem,
  ClientSubscription,
  DataType,
  MessageSecurityMode,
  OPCUAClient,
  SecurityPolicy,
  TimestampsToReturn,
  UserTokenType,
} from "node-opcua-client";
import { OPCUACertificateManager } from "node-opcua-certificate-manager";

const given = JSON.parse(process.argv[2]);
const scenarios = Array.isArray(given) ? given : [given];
let certificateManager = null;

function shown(dv) {
  return {
    status: dv.statusCode.name,
    value: dv.value ? dv.value.value : null,
    sourceTimestamp: dv.sourceTimestamp ? dv.sourceTimestamp.toISOString() : null,
  };
}

async function runStep(context, step) {
  const { session, items } = context;
  if (step.op === "browse") {
    const result = await session.browse(step.node);
    return {
      status: result.statusCode.name,
      names: result.references.map((r) => r.browseName.name),
      nodes: result.references.map((r) => r.nodeId.toString()),
    };
  } else if (step.op === "read") {
    const dv = await session.read({ nodeId: step.node, attributeId: AttributeIds.Value });
    return shown(dv);
  } else if (step.op === "call") {
    const result = await session.call({
      objectId: step.object,
      methodId: step.method,
      inputArguments: (step.args || []).map(([type, value]) => ({
        dataType: DataType[type],
        value,
      })),
    });
    return {
      status: result.statusCode.name,
      outputs: (result.outputArguments || []).map((v) => v.value),
    };
  } else if (step.op === "monitor") {
    if (context.subscription === null) {
      context.subscription = ClientSubscription.create(session, {
        requestedPublishingInterval: 50,
        requestedLifetimeCount: 600,
        requestedMaxKeepAliveCount: 20,
        maxNotificationsPerPublish: 1000,
        publishingEnabled: true,
        priority: 10,
      });
    }
    const seen = [];
    const item = ClientMonitoredItem.create(
      context.subscription,
      { nodeId: step.node, attributeId: AttributeIds.Value },
      { samplingInterval: 0, discardOldest: true, queueSize: 100 },
      TimestampsToReturn.Both,
    );
    item.on("changed", (dv) => {
      const report = shown(dv);
      seen.push(report);
      context.latest[step.name] = report;
    });
    items[step.name] = seen;
    return { status: "Good" };
  } else if (step.op === "await") {
    // what the item reported since the last await of it, until `value` came
    const seen = items[step.name];
    const until = Date.now() + (step.timeout || 20000);
    // a Good `value`, or (with "status") the first report of that status; with "latest",
    // until the item's latest report is that (the item may have reported it before)
    const wanted = step.status
      ? (s) => s.status === step.status
      : (s) => s.status === "Good" && s.value === step.value;
    const hit = step.latest
      ? () => context.latest[step.name] !== undefined && wanted(context.latest[step.name])
      : () => seen.some(wanted);
    while (!hit() && Date.now() < until) {
      await new Promise((resolve) => setTimeout(resolve, 20));
    }
    const reached = hit();
    return { status: reached ? "Good" : "Timeout", seen: seen.splice(0) };
  } else if (step.op === "parallel") {
    // its steps sent at once on the session (none waits for another's answer); `order`:
    // the indexes of the steps in the order their answers came
    const order = [];
    const results = await Promise.all(
      step.steps.map(async (inner, index) => {
        const result = await runStep(context, inner);
        order.push(index);
        return result;
      }),
    );
    return { status: "Good", order, results };
  } else {
    throw new Error(`unknown step ${step.op}`);
  }
}

async function run(scenario, out) {
  if (certificateManager === null) {
    certificateManager = new OPCUACertificateManager({
      rootFolder: scenario.pki,
      automaticallyAcceptUnknownCertificate: true,
    });
  }
  const client = OPCUAClient.create({
    applicationName: "rc233-gateway-tests",
    applicationUri: "urn:rc233-gateway-tests",
    securityMode: MessageSecurityMode[scenario.mode || "None"],
    securityPolicy: SecurityPolicy[scenario.policy || "None"],
    endpointMustExist: false,
    clientCertificateManager: certificateManager,
    connectionStrategy: { maxRetry: 0, initialDelay: 100, maxDelay: 200 },
    requestedSessionTimeout: 60000,
  });
  await client.connect(scenario.endpoint);
  let session;
  try {
    const identity = scenario.user
      ? { type: UserTokenType.UserName, userName: scenario.user, password: scenario.password }
      : { type: UserTokenType.Anonymous };
    session = await client.createSession(identity);
    out.connected = true;
    const context = { session, items: {}, latest: {}, subscription: null };
    for (const step of scenario.steps || []) {
      out.results.push(await runStep(context, step));
    }
    if (context.subscription !== null) await context.subscription.terminate();
  } finally {
    if (session) await session.close();
    await client.disconnect();
  }
}

async function main() {
  const outs = [];
  for (const scenario of scenarios) {
    const out = { connected: false, results: [] };
    try {
      await run(scenario, out);
    } catch (err) {
      out.error = String(err && err.message ? err.message : err);
    }
    outs.push(out);
  }
  // exit once written: a pipe takes 64 KiB at a time
  const text = JSON.stringify(Array.isArray(given) ? outs : outs[0]) + "\n";
  process.stdout.write(text, () => process.exit(0));
}

main();
