// The X-Cell 60 in the 3D view (view3d.js): its parts (xcell60.json, the shape the flight
// log also carries) as solids at their true dimensions, merged into one mesh a rigid piece,
// the rotors' turning blades, and the shadow on the ground.
import * as THREE from "./three.module.min.js";
import { LAYER, mergeGeometries } from "./field3d.js";

// Body FRD → the helicopter's own three.js axes (x right, y up, z back).
const frd3 = ([f, r, d]) => new THREE.Vector3(r, -d, -f);
const AXIS3 = { forward: new THREE.Vector3(0, 0, -1), right: new THREE.Vector3(1, 0, 0), down: new THREE.Vector3(0, -1, 0) };

// A part's solid as geometry in its piece's axes: turned, moved to its centre less
// `origin` (the piece's own), coloured by vertex (only position, normal and colour kept).
function partGeometry(part, origin) {
  const s = part.solid;
  let geometry;
  const q = new THREE.Quaternion();
  if (s.kind === "box") {
    geometry = new THREE.BoxGeometry(s.size_m[1], s.size_m[2], s.size_m[0]);
  } else if (s.kind === "ellipsoid") {
    geometry = new THREE.SphereGeometry(0.5, 20, 12);
    geometry.scale(s.size_m[1], s.size_m[2], s.size_m[0]);
  } else {
    // Along three.js's y, its top the axis's positive end.
    const round = Math.max(s.start_radius_m, s.end_radius_m) > 0.1 ? 40 : 10;
    geometry = new THREE.CylinderGeometry(s.end_radius_m, s.start_radius_m, s.length_m, round);
    q.setFromUnitVectors(new THREE.Vector3(0, 1, 0), AXIS3[s.axis]);
  }
  geometry.applyQuaternion(q);
  const at = frd3(part.center_frd_m.map((c, k) => c - origin[k]));
  geometry.translate(at.x, at.y, at.z);
  geometry.deleteAttribute("uv");
  const [r, g, b] = part.rgba;
  const color = new THREE.Color().setRGB(r, g, b, THREE.SRGBColorSpace);
  const n = geometry.attributes.position.count;
  const colors = new Float32Array(3 * n);
  for (let i = 0; i < n; i++) colors.set([color.r, color.g, color.b], 3 * i);
  geometry.setAttribute("color", new THREE.BufferAttribute(colors, 3));
  return geometry;
}

// The material of a piece whose parts have opacity `a` (their colours by vertex).
function pieceMaterial(a) {
  return new THREE.MeshLambertMaterial({
    vertexColors: true,
    transparent: a < 1,
    opacity: a,
    depthWrite: a >= 1,
    side: a < 1 ? THREE.DoubleSide : THREE.FrontSide,
  });
}

// Flattens onto the ground at height `y` along the direction `light` (toward the light).
export function shadowMatrix(light, y) {
  const [lx, ly, lz] = [light.x, light.y, light.z];
  return new THREE.Matrix4().set(
    ly, -lx, 0, lx * y,
    0, 0, 0, ly * y,
    0, -lz, ly, lz * y,
    0, 0, 0, ly);
}

// Builds the helicopter and its shadow into `view` (a HeliView) from `shape`.
export function buildHeli(view, shape) {
  view.heli = new THREE.Group();
  view.mainRotor = new THREE.Group();
  view.tailRotor = new THREE.Group();
  view.spinners = [];
  const hub = (group) => {
    const parts = shape.parts.filter((p) => p.group === group);
    return parts.length ? parts[0].center_frd_m : [0, 0, 0];
  };
  const mainHub = hub("main_rotor"), tailHub = hub("tail_rotor");
  view.mainRotor.position.copy(frd3(mainHub));
  view.tailRotor.position.copy(frd3(tailHub));
  view.heli.add(view.mainRotor, view.tailRotor);
  // The parts merged into one mesh a rigid piece and opacity (a software renderer's time
  // goes with its draw calls as well as its pixels: drawn part by part, the helicopter and
  // its shadow were 30 of a view's 47): the airframe; each rotor's disk; each rotor's
  // turning blades, with the flybar (about the mast or the tail rotor's shaft).
  const pieces = new Map();
  for (const part of shape.parts) {
    let parent = view.heli, origin = [0, 0, 0];
    if (part.group === "main_rotor") { parent = view.mainRotor; origin = mainHub; }
    if (part.group === "tail_rotor") { parent = view.tailRotor; origin = tailHub; }
    const spins = part.name.endsWith("blades") || part.name === "flybar";
    const alpha = part.rgba[3];
    const key = `${part.group} ${spins} ${alpha}`;
    if (!pieces.has(key)) {
      pieces.set(key, { parent, spins, alpha, axis: part.group === "tail_rotor" ? "x" : "y", parts: [] });
    }
    pieces.get(key).parts.push(partGeometry(part, origin));
  }
  for (const piece of pieces.values()) {
    const mesh = new THREE.Mesh(mergeGeometries(piece.parts), pieceMaterial(piece.alpha));
    for (const g of piece.parts) g.dispose();
    mesh.layers.set(LAYER.heli);
    if (piece.spins) {
      const spinner = new THREE.Group();
      spinner.add(mesh);
      spinner.userData.axis = piece.axis;
      piece.parent.add(spinner);
      view.spinners.push(spinner);
    } else {
      piece.parent.add(mesh);
    }
  }
  // The corners of the box that holds the helicopter, to measure it on screen.
  const [lo, hi] = shape.bounds_frd_m;
  view.corners = [];
  for (const f of [lo[0], hi[0]]) for (const r of [lo[1], hi[1]]) for (const d of [lo[2], hi[2]]) {
    view.corners.push(frd3([f, r, d]));
  }
  view.rotor_m = shape.rotor_diameter_m;
  // The farthest of them from the helicopter's centre (m): what the framing keeps in view.
  view.reach_m = Math.max(...view.corners.map((c) => c.length()));
  view.scene.add(view.heli);
  // The shadow: every part again, flattened onto the ground along the sun (the spinning
  // rotor's disk a faint one, as on a sunny field).
  view.shadows = [];
  const dark = new THREE.MeshBasicMaterial({ color: 0x000000, transparent: true, opacity: 0.38, depthWrite: false });
  const faint = new THREE.MeshBasicMaterial({ color: 0x000000, transparent: true, opacity: 0.12, depthWrite: false, side: THREE.DoubleSide });
  view.heli.traverse((o) => {
    if (!o.isMesh) return;
    const s = new THREE.Mesh(o.geometry, o.material.opacity < 1 ? faint : dark);
    s.matrixAutoUpdate = false;
    s.layers.set(LAYER.shadow);
    s.userData.of = o;
    view.scene.add(s);
    view.shadows.push(s);
  });
}
