// The world round the helicopter in the 3D view (view3d.js): sky, mown field with the
// take-off pad, distance rings and their labels, the pilot's stand, the wind sock, the plan
// and the trail; and what the view's other parts share: the sun, the layers by which it
// counts rendered pixels, the NED-to-three.js axes, geometry merging.
import * as THREE from "./three.module.min.js";

// Where the sun is (three.js axes, toward the light): high in the south-west.
export const SUN = new THREE.Vector3(-0.25, 1.0, 0.2).normalize();
export const SKY_ZENITH = new THREE.Color(0x3f7fc8);
export const SKY_HORIZON = new THREE.Color(0xcfe0ee);
// The sky's dome round the eye (m): farther than the field's corners, nearer than the far plane.
export const SKY_RADIUS_M = 3500;
// Layers, for counting rendered pixels.
export const LAYER = { heli: 1, shadow: 2, sky: 3, ground: 4 };

// NED → three.js.
export const ned3 = (n, e, d) => new THREE.Vector3(e, -d, -n);

// A texture drawn on a canvas by `paint(g, size)`.
export function canvasTexture(size, paint, width) {
  const c = document.createElement("canvas");
  c.width = width || size;
  c.height = size;
  paint(c.getContext("2d"), size);
  const t = new THREE.CanvasTexture(c);
  t.colorSpace = THREE.SRGBColorSpace;
  return t;
}

// Mown grass: a 10 m tile, two 5 m stripes, speckled.
export function grassTexture() {
  const t = canvasTexture(128, (g, n) => {
    g.fillStyle = "#4f7d36"; g.fillRect(0, 0, n, n / 2);
    g.fillStyle = "#5b8b3e"; g.fillRect(0, n / 2, n, n / 2);
    let seed = 7;
    const rnd = () => ((seed = (seed * 16807) % 2147483647) / 2147483647);
    for (let k = 0; k < 2500; k++) {
      const v = Math.floor(rnd() * 40) - 20;
      g.fillStyle = `rgba(${90 + v},${130 + v},${60 + v},0.55)`;
      g.fillRect(rnd() * n, rnd() * n, 1.5, 1.5);
    }
  });
  t.wrapS = t.wrapT = THREE.RepeatWrapping;
  return t;
}

// The distance rings' labels, as one mesh of quads that turn to face each camera before it
// draws (`face`), their texts side by side in one texture: one draw call, not one a label.
export class Labels {
  constructor(texts, width_m) {
    this.index = new Map(texts.map((t, k) => [t, k]));
    const n = texts.length;
    const map = canvasTexture(128, (g, h) => {
      g.font = "bold 44px system-ui, sans-serif";
      g.textAlign = "center";
      g.textBaseline = "middle";
      g.lineWidth = 8;
      g.strokeStyle = "rgba(0,0,0,0.6)";
      g.fillStyle = "#ffffff";
      texts.forEach((text, k) => {
        g.strokeText(text, h * (k + 0.5), h / 2);
        g.fillText(text, h * (k + 0.5), h / 2);
      });
    }, 128 * n);
    this.width_m = width_m;
    this.cells = n;
    this.places = [];
    this.mesh = new THREE.Mesh(new THREE.BufferGeometry(),
      new THREE.MeshBasicMaterial({ map, transparent: true, depthWrite: false }));
    this.mesh.frustumCulled = false;
  }

  // A label `text` (one of the texts) centred at `at` (its group's axes).
  add(text, at) { this.places.push([this.index.get(text), at.clone()]); }

  // Builds the quads once every label is added.
  build() {
    const m = this.places.length;
    const g = this.mesh.geometry;
    g.setAttribute("position", new THREE.BufferAttribute(new Float32Array(12 * m), 3));
    const uv = new Float32Array(8 * m), index = [];
    this.places.forEach(([cell, ], q) => {
      const [u0, u1] = [cell / this.cells, (cell + 1) / this.cells];
      uv.set([u0, 0, u1, 0, u1, 1, u0, 1], 8 * q);
      index.push(4 * q, 4 * q + 1, 4 * q + 2, 4 * q, 4 * q + 2, 4 * q + 3);
    });
    g.setAttribute("uv", new THREE.BufferAttribute(uv, 2));
    g.setIndex(index);
  }

  // Turns every quad to face `cam` (the screen's right and up, as sprites do).
  face(cam) {
    const e = cam.matrixWorld.elements;
    const half = this.width_m / 2;
    const right = new THREE.Vector3(e[0], e[1], e[2]).normalize().multiplyScalar(half);
    const up = new THREE.Vector3(e[4], e[5], e[6]).normalize().multiplyScalar(half);
    const p = this.mesh.geometry.attributes.position;
    this.places.forEach(([, at], q) => {
      [[-1, -1], [1, -1], [1, 1], [-1, 1]].forEach(([a, b], k) => {
        p.setXYZ(4 * q + k, at.x + a * right.x + b * up.x, at.y + a * right.y + b * up.y,
          at.z + a * right.z + b * up.z);
      });
    });
    p.needsUpdate = true;
  }
}

// Merges `geometries` (indexed, with the same attributes) into one: the helicopter's parts
// of one rigid piece, the distance rings.
export function mergeGeometries(geometries) {
  const names = Object.keys(geometries[0].attributes);
  let vertices = 0, indices = 0;
  for (const g of geometries) { vertices += g.attributes.position.count; indices += g.index.count; }
  const out = new THREE.BufferGeometry();
  for (const name of names) {
    const size = geometries[0].attributes[name].itemSize;
    const data = new Float32Array(size * vertices);
    let at = 0;
    for (const g of geometries) { data.set(g.attributes[name].array, at); at += g.attributes[name].array.length; }
    out.setAttribute(name, new THREE.BufferAttribute(data, size));
  }
  const index = new Uint32Array(indices);
  let [at, base] = [0, 0];
  for (const g of geometries) {
    for (let i = 0; i < g.index.count; i++) index[at + i] = g.index.array[i] + base;
    at += g.index.count;
    base += g.attributes.position.count;
  }
  out.setIndex(new THREE.BufferAttribute(index, 1));
  out.computeBoundingSphere();
  return out;
}

// Builds the world into `view` (a HeliView): its scene's lights, sky, ground, field, sock,
// plan and trail.
export function buildWorld(view) {
  const s = view.scene;
  s.add(new THREE.HemisphereLight(0xdfeaff, 0x4a5a30, 1.6));
  const sun = new THREE.DirectionalLight(0xffffff, 2.2);
  sun.position.copy(SUN).multiplyScalar(100);
  s.add(sun);
  // Sky: a dome that follows the eye, pale at the horizon, blue above.
  // Drawn after the opaque ground and helicopter, where they leave sky, so that a software
  // renderer fills each of those pixels once; beyond the ground's far edge (2.8 km from
  // the take-off point at its corners) and inside the camera's far plane.
  const dome = new THREE.SphereGeometry(SKY_RADIUS_M, 32, 16);
  const colors = [];
  const p = dome.attributes.position;
  for (let i = 0; i < p.count; i++) {
    const up = Math.max(0, p.getY(i) / SKY_RADIUS_M);
    const c = SKY_HORIZON.clone().lerp(SKY_ZENITH, Math.pow(up, 0.6));
    colors.push(c.r, c.g, c.b);
  }
  dome.setAttribute("color", new THREE.Float32BufferAttribute(colors, 3));
  view.sky = new THREE.Mesh(dome, new THREE.MeshBasicMaterial({
    vertexColors: true, side: THREE.BackSide, fog: false, depthWrite: false }));
  view.sky.renderOrder = 1;
  view.sky.layers.set(LAYER.sky);
  s.add(view.sky);
  // The field: mown grass to the horizon (fog blends it into the sky).
  const grass = grassTexture();
  grass.repeat.set(400, 400);
  grass.anisotropy = 1;
  grass.minFilter = THREE.NearestMipmapNearestFilter;
  view.ground = new THREE.Mesh(new THREE.PlaneGeometry(4000, 4000),
    new THREE.MeshBasicMaterial({ map: grass }));
  view.ground.rotation.x = -Math.PI / 2;
  view.ground.layers.set(LAYER.ground);
  s.add(view.ground);
  // The take-off pad, the distance rings and their labels, the pilot's stand.
  view.field = new THREE.Group();
  const pad = new THREE.Mesh(new THREE.CircleGeometry(1.2, 32), new THREE.MeshLambertMaterial({
    map: canvasTexture(128, (g, n) => {
      g.fillStyle = "#9a9a94"; g.fillRect(0, 0, n, n);
      g.fillStyle = "#f4f4f0"; g.font = "bold 90px system-ui, sans-serif";
      g.textAlign = "center"; g.textBaseline = "middle"; g.fillText("H", n / 2, n / 2 + 4);
    }),
    polygonOffset: true, polygonOffsetFactor: -2 }));
  pad.rotation.x = -Math.PI / 2;
  pad.rotation.z = Math.PI;
  pad.position.y = 0.01;
  view.field.add(pad);
  // The rings as one mesh, their labels as another.
  const radii = [10, 20, 30, 50];
  view.labels = new Labels(radii.map((r) => `${r} m`), 1.6);
  const rings = radii.map((r) => {
    const ring = new THREE.RingGeometry(r - 0.15, r + 0.15, 96);
    ring.rotateX(-Math.PI / 2);
    ring.translate(0, 0.02, 0);
    // Labelled ahead and to the sides (not under the pilot's feet).
    for (const [n, e] of [[r, 0], [0, r], [0, -r]]) view.labels.add(`${r} m`, ned3(n, e, -0.6));
    return ring;
  });
  view.field.add(new THREE.Mesh(mergeGeometries(rings),
    new THREE.MeshBasicMaterial({ color: 0xf0f0e8, transparent: true, opacity: 0.7, depthWrite: false })));
  view.labels.build();
  view.field.add(view.labels.mesh);
  view.stand = new THREE.Mesh(new THREE.CircleGeometry(0.4, 20),
    new THREE.MeshBasicMaterial({ color: 0xff8a1c }));
  view.stand.rotation.x = -Math.PI / 2;
  view.field.add(view.stand);
  // The wind sock: a 3 m pole 8 m east of the pad, its sock downwind, drooping in a calm.
  view.sock = new THREE.Group();
  const pole = new THREE.Mesh(new THREE.CylinderGeometry(0.03, 0.04, 3, 8),
    new THREE.MeshLambertMaterial({ color: 0xdddddd }));
  pole.position.y = 1.5;
  view.sock.add(pole);
  view.sockPivot = new THREE.Group();
  view.sockPivot.position.y = 3;
  const cone = new THREE.ConeGeometry(0.22, 1.3, 12, 1, true);
  cone.rotateX(Math.PI / 2); // along +z, the narrow end at +z
  cone.translate(0, 0, 0.65);
  const sockMesh = new THREE.Mesh(cone, new THREE.MeshLambertMaterial({ color: 0xff5a1c, side: THREE.DoubleSide }));
  view.sockPivot.add(sockMesh);
  view.sock.add(view.sockPivot);
  view.sock.position.copy(ned3(0, 8, 0));
  view.field.add(view.sock);
  s.add(view.field);
  // The plan (dashed) and the trail.
  view.plan = new THREE.Line(new THREE.BufferGeometry(),
    new THREE.LineDashedMaterial({ color: 0xc792ea, dashSize: 1.2, gapSize: 0.8 }));
  view.planKey = "";
  s.add(view.plan);
  view.trailPositions = new Float32Array(3 * 2000);
  const trail = new THREE.BufferGeometry();
  trail.setAttribute("position", new THREE.BufferAttribute(view.trailPositions, 3));
  view.trail = new THREE.Line(trail, new THREE.LineBasicMaterial({ color: 0x2f6fb8 }));
  view.trail.frustumCulled = false;
  s.add(view.trail);
}

