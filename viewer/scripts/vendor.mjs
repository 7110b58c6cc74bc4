// Copies the viewer's libraries from node_modules into vendor/ (committed,
// embedded in the binary), with their licences. Run after changing the
// versions in package.json: `npm install && npm run vendor`.
import { copyFileSync, mkdirSync } from "node:fs";

const files = [
  ["three/build/three.module.min.js", "three.module.min.js"],
  ["three/build/three.core.min.js", "three.core.min.js"],
  ["three/examples/jsm/controls/OrbitControls.js", "OrbitControls.js"],
  ["three/LICENSE", "LICENSE-three.txt"],
  ["uplot/dist/uPlot.iife.min.js", "uPlot.iife.min.js"],
  ["uplot/dist/uPlot.min.css", "uPlot.min.css"],
  ["uplot/LICENSE", "LICENSE-uplot.txt"],
];
mkdirSync("vendor", { recursive: true });
for (const [from, to] of files) {
  copyFileSync(`node_modules/${from}`, `vendor/${to}`);
  console.log(`vendor/${to}`);
}
