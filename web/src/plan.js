// The site plan as SVG: floors, structure, zones, elements by status (found outline filled, the BIM's dashed),
// and the robot's path with its stations. World metres, y up (flipped into SVG's y down).
import { svg } from "./format.js";

const MARGIN = 0.8;

export function drawPlan(root, plan, onPick) {
  root.replaceChildren();
  const [xmin, ymin, xmax, ymax] = plan.bounds;
  root.setAttribute("viewBox", `${xmin - MARGIN} ${-ymax - MARGIN} ${xmax - xmin + 2 * MARGIN} ${ymax - ymin + 2 * MARGIN}`);
  root.setAttribute("preserveAspectRatio", "xMidYMid meet");
  const defs = svg("defs");
  const hatch = svg("pattern", { id: "hatch", width: 0.4, height: 0.4, patternUnits: "userSpaceOnUse", patternTransform: "rotate(45)" });
  hatch.append(svg("line", { x1: 0, y1: 0, x2: 0, y2: 0.4, class: "hatch" }));
  const arrow = svg("marker", { id: "arrow", viewBox: "0 0 10 10", refX: 8, refY: 5, markerWidth: 5, markerHeight: 5, orient: "auto-start-reverse" });
  arrow.append(svg("path", { d: "M 0 0 L 10 5 L 0 10 z", class: "arrowhead" }));
  defs.append(hatch, arrow);
  const world = svg("g", { transform: "scale(1,-1)" });
  root.append(defs, world);
  const points = (outline) => outline.map(([x, y]) => `${x},${y}`).join(" ");
  for (const floor of plan.floors) world.append(svg("polygon", { points: points(floor.outline), class: "floor" }));
  for (const zone of plan.zones) {
    const shape = svg("polygon", { points: points(zone.outline), class: zone.off_limits ? "zone off-limits" : "zone" });
    shape.append(title(`${zone.name || "zone"}${zone.off_limits ? " (off limits)" : ""}`));
    world.append(shape);
  }
  for (const part of plan.structure) {
    const shape = svg("polygon", { points: points(part.outline), class: "structure" });
    shape.append(title(`${part.ifc_class} ${part.name || ""}`));
    world.append(shape);
  }
  for (const element of plan.elements) {
    if (element.planned && element.status !== "as planned") {
      world.append(svg("polygon", { points: points(element.planned), class: "planned" }));
    }
    if (!element.outline || element.outline.length < 2) continue;
    const shape = svg("polygon", { points: points(element.outline), class: "element", fill: element.colour, "data-gid": element.global_id, "data-status": element.status });
    shape.append(title(`${element.family || element.global_id}: ${element.status}`));
    shape.addEventListener("click", () => onPick(element.global_id));
    world.append(shape);
  }
  const path = plan.robot_path;
  if (path.length > 1) {
    world.append(svg("polyline", { points: path.map((p) => `${p.x},${p.y}`).join(" "), class: "path", "marker-mid": "url(#arrow)", "marker-end": "url(#arrow)" }));
  }
  path.forEach((p, i) => {
    const dot = svg("circle", { cx: p.x, cy: p.y, r: i === 0 ? 0.22 : 0.14, class: i === 0 ? "station first" : "station" });
    dot.append(title(`station ${p.station ?? i} · ${p.robot}`));
    world.append(dot);
  });
}

function title(text) {
  const node = svg("title");
  node.textContent = text;
  return node;
}

export function recolour(root, element) {
  for (const shape of root.querySelectorAll(`[data-gid="${CSS.escape(element.global_id)}"]`)) {
    shape.setAttribute("fill", element.colour);
    shape.setAttribute("data-status", element.status);
  }
}
