// Load an SCXML document in SCION and replay input sequences through it.
// Usage: node replay.js FILE.scxml [data] < sequences.json, where the JSON is a list of sequences, each a list of
// objects (the inputs of one step: booleans, and numbers for a machine with data). Prints one JSON line per
// sequence: the list of state configurations, the initial one first; with `data`, the list of snapshots
// {state, v, o} (the configuration and the datamodel's variables and outputs). Exit 2 when SCION rejects the
// document.
"use strict";
const scxml = require("@scion-scxml/scxml");
const fs = require("fs");

const sequences = JSON.parse(fs.readFileSync(0, "utf8"));
// Each sequence runs on a model prepared for it alone: charts made from one prepared model share its datamodel.
function replay(model, k) {
  if (k === sequences.length) return;
  model.prepare((err, fnModel) => {
    if (err) { console.error(String(err)); process.exit(2); }
    const chart = new scxml.core.Statechart(fnModel);
    const snapshot = (configuration) => {
      if (process.argv[3] !== "data") return configuration;
      const datamodel = chart.getSnapshot()[3];  // live values: copied now, before the next step
      return JSON.parse(JSON.stringify({ state: configuration, v: datamodel.v, o: datamodel.o }));
    };
    const steps = [snapshot(chart.start())];
    for (const inputs of sequences[k]) {
      steps.push(snapshot(chart.gen({ name: "step", data: inputs })));
    }
    console.log(JSON.stringify(steps));
    replay(model, k + 1);
  });
}

scxml.pathToModel(process.argv[2], (err, model) => {
  if (err) { console.error(String(err)); process.exit(2); }
  replay(model, 0);
});
