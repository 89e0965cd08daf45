#include "storey/tools/report_view.h"

#include <cmath>
#include <cstdio>
#include <string>

#include "storey/tools/building_report.h"

namespace storey::tools {

namespace {

std::string hexColour(const building::Colour& c) {
  char text[8];
  std::snprintf(text, sizeof text, "#%02x%02x%02x", c[0], c[1], c[2]);
  return text;
}

long long centimetres(double metres) { return std::llround(metres * 100.0); }

void writeLine(std::ostream& out, const building::SceneLine& line, const char* kind) {
  out << "{\"f\":" << line.floor_id << ",\"k\":\"" << kind << "\",\"c\":\""
      << hexColour(line.colour) << "\",\"p\":[";
  for (std::size_t i = 0; i < line.points.size(); ++i)
    out << (i ? "," : "") << centimetres(line.points[i].x()) << ','
        << centimetres(line.points[i].y()) << ',' << centimetres(line.points[i].z());
  out << "]}";
}

// Draws the scene in data element "view3d-data" on canvas "view3d": orbit by dragging,
// pan with shift or the right button, zoom with the wheel, reset with a double click.
// Floors lowest first, each with its outline, walls, label and paths; then rides and
// constraints.
constexpr const char* kViewScript = R"JS(
(function () {
  const data = JSON.parse(document.getElementById("view3d-data").textContent);
  const canvas = document.getElementById("view3d");
  const ctx = canvas.getContext("2d");
  const floors = data.floors.map(f => {
    const w = Float64Array.from(f.w, v => v / 100);
    let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
    for (let i = 0; i < w.length; i += 2) {
      x0 = Math.min(x0, w[i]); x1 = Math.max(x1, w[i]);
      y0 = Math.min(y0, w[i + 1]); y1 = Math.max(y1, w[i + 1]);
    }
    return {id: f.id, z: f.z, c: f.c, w: w, box: [x0 - 1, y0 - 1, x1 + 1, y1 + 1], shown: true};
  });
  const lines = data.lines.map(l => ({f: l.f, k: l.k, c: l.c, p: l.p.map(v => v / 100)}));
  if (floors.length === 0) return;
  const box = [Infinity, Infinity, -Infinity, -Infinity];
  for (const f of floors) {
    box[0] = Math.min(box[0], f.box[0]); box[1] = Math.min(box[1], f.box[1]);
    box[2] = Math.max(box[2], f.box[2]); box[3] = Math.max(box[3], f.box[3]);
  }
  const zs = floors.map(f => f.z);
  const zlow = Math.min(...zs), zhigh = Math.max(...zs);
  // Heights stretched so that one storey spans about a quarter of the plan: floors a few
  // metres apart under a plan tens of metres wide would hide each other.
  const gaps = zs.slice(1).map((z, i) => z - zs[i]).filter(g => g > 1e-6).sort((a, b) => a - b);
  const span = Math.max(box[2] - box[0], box[3] - box[1], 1);
  const stretch = gaps.length ? Math.max(1, 0.25 * span / gaps[gaps.length >> 1]) : 1;
  const initial = {yaw: Math.PI / 4, pitch: Math.PI / 6, zoom: 1, stretch: 1, dx: 0, dy: 0};
  const view = Object.assign({}, initial);
  const show = {paths: true, constraints: true};
  let fit = null;

  function draw() {
    const W = canvas.width, H = canvas.height;
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, W, H);
    const s = stretch * view.stretch;
    const cy = Math.cos(view.yaw), sy = Math.sin(view.yaw);
    const cp = Math.cos(view.pitch), sp = Math.sin(view.pitch);
    const xm = (box[0] + box[2]) / 2, ym = (box[1] + box[3]) / 2, zm = (zlow + zhigh) / 2;
    const project = (x, y, z, k) => {
      const dx = x - xm, dy = y - ym, dz = (z - zm) * s;
      const far = sy * dx + cy * dy;
      return [W / 2 + view.dx + k * (cy * dx - sy * dy), H / 2 + view.dy - k * (far * sp + dz * cp)];
    };
    // Scale: the building's corners fill the canvas as first drawn (and when its heights are
    // restretched); turning and zooming keep it.
    if (!fit || fit.s !== s) {
      let u = 0, v = 0;
      for (const x of [box[0], box[2]]) for (const y of [box[1], box[3]]) for (const z of [zlow, zhigh]) {
        const [pu, pv] = project(x, y, z, 1);
        u = Math.max(u, Math.abs(pu - W / 2 - view.dx));
        v = Math.max(v, Math.abs(pv - H / 2 - view.dy));
      }
      fit = {s: s, k: 0.46 * Math.min(W / u, H / v)};
    }
    const at = (x, y, z) => project(x, y, z, fit.k * view.zoom);
    const polyline = l => {
      ctx.strokeStyle = l.c;
      ctx.beginPath();
      for (let i = 0; i < l.p.length; i += 3) {
        const [u, v] = at(l.p[i], l.p[i + 1], l.p[i + 2]);
        if (i === 0) ctx.moveTo(u, v); else ctx.lineTo(u, v);
      }
      ctx.stroke();
    };
    ctx.lineWidth = 1.5;
    ctx.font = "12px sans-serif";
    for (const f of floors) {
      if (!f.shown) continue;
      const [x0, y0, x1, y1] = f.box;
      polyline({c: "#aaa", p: [x0, y0, f.z, x1, y0, f.z, x1, y1, f.z, x0, y1, f.z, x0, y0, f.z]});
      ctx.fillStyle = f.c;
      for (let i = 0; i < f.w.length; i += 2) {
        const [u, v] = at(f.w[i], f.w[i + 1], f.z);
        ctx.fillRect(u - 1, v - 1, 2, 2);
      }
      // The label left of the outline's leftmost corner.
      let left = null;
      for (const [x, y] of [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) {
        const p = at(x, y, f.z);
        if (!left || p[0] < left[0]) left = p;
      }
      ctx.fillStyle = "#000";
      ctx.textAlign = "right";
      ctx.fillText("floor " + f.id, left[0] - 4, left[1] + 4);
      if (show.paths) for (const l of lines) if (l.k === "path" && l.f === f.id) polyline(l);
    }
    for (const l of lines)
      if ((l.k === "ride" && show.paths) || (l.k === "constraint" && show.constraints)) polyline(l);
  }

  const controls = document.getElementById("view3d-controls");
  const box_for = (label, checked, change) => {
    const l = document.createElement("label");
    const input = document.createElement("input");
    input.type = "checkbox";
    input.checked = checked;
    input.addEventListener("change", () => { change(input.checked); draw(); });
    l.style.whiteSpace = "nowrap";
    l.style.marginRight = "10px";
    l.append(input, " " + label);
    controls.append(l);
    return input;
  };
  for (const f of floors) {
    const input = box_for("floor " + f.id + " (" + f.z.toFixed(2) + " m)", true, on => { f.shown = on; });
    input.dataset.floor = f.id;
    input.style.accentColor = f.c;
  }
  box_for("paths and rides", true, on => { show.paths = on; });
  box_for("constraints", true, on => { show.constraints = on; });
  const slider = document.createElement("input");
  slider.type = "range"; slider.min = "0"; slider.max = "4"; slider.step = "0.1"; slider.value = "1";
  slider.addEventListener("input", () => { view.stretch = Number(slider.value); draw(); });
  const stretch_label = document.createElement("label");
  stretch_label.style.whiteSpace = "nowrap";
  stretch_label.append("heights \u00d7 ", slider);
  controls.append(stretch_label);

  let drag = null;
  canvas.addEventListener("contextmenu", e => e.preventDefault());
  canvas.addEventListener("pointerdown", e => {
    drag = {x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button === 2};
    e.preventDefault();
  });
  window.addEventListener("pointermove", e => {
    if (!drag) return;
    const mx = e.clientX - drag.x, my = e.clientY - drag.y;
    if (drag.pan) { view.dx += mx; view.dy += my; } else {
      view.yaw += mx * 0.01;
      view.pitch = Math.min(Math.PI / 2, Math.max(0, view.pitch + my * 0.01));
    }
    drag.x = e.clientX; drag.y = e.clientY;
    draw();
  });
  window.addEventListener("pointerup", () => { drag = null; });
  canvas.addEventListener("wheel", e => {
    e.preventDefault();
    view.zoom = Math.min(100, Math.max(0.2, view.zoom * Math.exp(-e.deltaY * 0.002)));
    draw();
  }, {passive: false});
  canvas.addEventListener("dblclick", () => {
    Object.assign(view, initial);
    slider.value = "1";
    draw();
  });
  draw();
})();
)JS";

}  // namespace

void writeInteractiveView(std::ostream& out, building::BuildingScene scene) {
  const double cell = building::thinWalls(scene, 0.1, kViewWallPoints);
  std::size_t points = 0;
  for (const auto& f : scene.floors) points += f.walls.size();
  out << "<h2>3D view</h2>\n<p>The floors at their heights (walls one point per "
      << fixedText(cell, 1) << " m square, " << points
      << " points), robots' paths and rides, inter-floor constraints in black. Drag to turn, "
         "shift-drag or right-drag to move, wheel to zoom, double-click to reset.</p>\n"
         "<canvas id=\"view3d\" width=\"1060\" height=\"640\" style=\"border:1px solid "
         "#ccc;touch-action:none;max-width:100%\"></canvas>\n<div id=\"view3d-controls\"></div>\n"
         "<script type=\"application/json\" id=\"view3d-data\">{\"floors\":[";
  for (std::size_t i = 0; i < scene.floors.size(); ++i) {
    const building::SceneFloor& f = scene.floors[i];
    out << (i ? ",\n" : "") << "{\"id\":" << f.floor_id << ",\"z\":" << fixedText(f.height, 3)
        << ",\"c\":\"" << hexColour(f.colour) << "\",\"w\":[";
    for (std::size_t j = 0; j < f.walls.size(); ++j)
      out << (j ? "," : "") << centimetres(f.walls[j].x()) << ',' << centimetres(f.walls[j].y());
    out << "]}";
  }
  out << "],\n\"lines\":[";
  bool first = true;
  auto lines = [&](const std::vector<building::SceneLine>& list, const char* kind) {
    for (const auto& l : list) {
      out << (first ? "" : ",\n");
      first = false;
      writeLine(out, l, kind);
    }
  };
  lines(scene.paths, "path");
  lines(scene.rides, "ride");
  lines(scene.constraints, "constraint");
  out << "]}</script>\n<script>" << kViewScript << "</script>\n";
}

}  // namespace storey::tools
