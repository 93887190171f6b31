// Load an SCXML document in SCION and replay input sequences through it.
// Usage: node replay.js FILE.scxml < sequences.json, where the JSON is a list of sequences, each a list of
// objects of booleans (the inputs of one step). Prints one JSON line per sequence: the list of state
// configurations, the initial one first. Exit 2 when SCION rejects the document.
"use strict";
const scxml = require("@scion-scxml/scxml");
const fs = require("fs");

const sequences = JSON.parse(fs.readFileSync(0, "utf8"));
scxml.pathToModel(process.argv[2], (err, model) => {
  if (err) { console.error(String(err)); process.exit(2); }
  model.prepare((err2, fnModel) => {
    if (err2) { console.error(String(err2)); process.exit(2); }
    for (const sequence of sequences) {
      const chart = new scxml.core.Statechart(fnModel);
      const configurations = [chart.start()];
      for (const inputs of sequence) {
        configurations.push(chart.gen({ name: "step", data: inputs }));
      }
      console.log(JSON.stringify(configurations));
    }
  });
});
