// The 3D view of the X-Cell 60, drawn with three.js (vendored: three.module.min.js, MIT,
// three.LICENSE.txt): the helicopter as solids at its true dimensions (xcell60.json, the shape
// the flight log also carries), its main rotor disk tilted by the flapping with spinning
// blades, its shadow on a mown field with the take-off pad and distance rings, sky and
// horizon, the plan and the trail, a wind sock. Cameras: the pilot's (standing where an RC
// pilot stands, turning to the helicopter and zooming to keep it a flyable size with the
// shadow and the horizon in view where they fit), chase and top.
//
// Frames (the same as the flight software's): world NED (north, east, down) from the
// take-off point, body FRD (forward, right, down). three.js draws in x east, y up, z south.
//
//   const view = await HeliView.create(canvas, { camera: "pilot", inset: { camera: "chase",
//                                                x: 860, y: 12, w: 400, h: 250 } });
//   view.render({ pos_ned_m, euler_rad, flap_rad, rotor_rpm, wind_ned_mps }, history, plan,
//               home, { produced_ms })   // once per animation frame
//
// Every render returns, for each camera, what it shows (the helicopter's size on screen,
// whether its shadow and the horizon are in view, frames per second, the state-to-frame
// latency); `measure(k)` counts camera k's rendered pixels of the helicopter, its shadow, the
// sky and the ground.
import * as THREE from "./three.module.min.js";
import { LAYER, SKY_HORIZON, SUN, buildWorld, ned3 } from "./field3d.js";
import { buildHeli, shadowMatrix } from "./xcell3d.js";

const DEG = Math.PI / 180;
// The pilot's eye above the ground (m), and where the pilot stands from the take-off point
// (m north, m east) unless placed elsewhere: 15 m behind the pad, as at a flying field's
// pilot station.
const PILOT_EYE_M = 1.7;
const PILOT_DEFAULT_NE = [-15, 0];
// The framing (px on screen): the helicopter's rotor TARGET_HELI_PX across when no ground
// cue is framed (auto-zoom); never under MIN_HELI_PX when the view widens for the cues (a
// little over the 40 px a pilot needs: a software renderer drawing at a quarter of the scale
// rounds it to 4 px), or under MIN_HELI_PX - HOLD_SLACK_PX for a cue the last frame held
// (a new cue also wants FOV_SLACK_DEG of room under the widest view);
// never more than MAX_SHARE of the view's height; the shadow framed only where it is
// SHADOW_LEAST_PX tall or more; MARGIN_PX between what is framed and the view's edge. The
// zoom's limits (vertical field of view, degrees), the chase camera's wider.
const TARGET_HELI_PX = 80;
const MIN_HELI_PX = 44;
const HOLD_SLACK_PX = 2;
const FOV_SLACK_DEG = 2;
const SHADOW_LEAST_PX = 3;
const MAX_SHARE = 0.3;
const MARGIN_PX = 6;
const FOV_MIN_DEG = 3;
const FOV_MAX_DEG = 60;
const CHASE_FOV_MAX_DEG = 80;
// The chase camera: behind the helicopter and above it (m).
const CHASE_BACK_M = 5;
const CHASE_UP_M = 1.5;
// The drawing's resolution (its scale: a share of the canvas's width and height, the pixels
// drawn its square) where it adapts to hold the frame rate: a software renderer's time goes
// with the pixels it fills (on a 2-core machine, 1280x1024 drawn whole: 8 frames a second;
// at half scale: 18 to 50, as the host allows). It counts the frames drawn, so it suits a page
// that draws on every animation frame. Under TARGET_FPS two seconds running, the scale drops to what should give FPS_AIM (the fill being
// what costs); at RAISE_FPS_AT or more three seconds running, it rises by RAISE_STEP (a step
// up would still give FPS_AIM). Never under MIN_RESOLUTION.
const TARGET_FPS = 30;
const FPS_AIM = 36;
const RAISE_STEP = 1.2;
const RAISE_FPS_AT = FPS_AIM * RAISE_STEP * RAISE_STEP;
const MIN_RESOLUTION = 0.25;
// The framing of a view `h` px tall (its vertical field of view FOV_MIN_DEG to `fovMax_deg`)
// that turns to the helicopter, seen at elevation `eHeli_deg` with its rotor's half-angle
// `rho_deg` (its width) and its whole reach's `reach_deg` (what must stay inside the edges:
// the tail rotor reaches past the main rotor's tips), and takes in as many of the ground cues
// `cues` as fit: [lowest, highest] elevation (degrees) and the least height on screen (px)
// that makes it worth having (a shadow far off is a line under a pixel tall), in order of
// preference. Returns the view's centre (elevation) and field of view (degrees), which cues
// it holds (`held`, one flag a cue), and the helicopter's width on screen (px). Every cue
// held is kept at its least height and the helicopter at MIN_HELI_PX across in the view
// finally chosen; a cue the last frame held (`heldBefore`) with MIN_HELI_PX - HOLD_SLACK_PX
// and up to the widest view, a new one only with MIN_HELI_PX and FOV_SLACK_DEG short of it,
// so that the view does not jump in and out at a limit from frame to frame.
export function frameCues(h, fovMax_deg, eHeli_deg, rho_deg, cues, heldBefore = [], reach_deg = rho_deg) {
  const tanRho = Math.tan(rho_deg * DEG);
  const fovOf = (f) => (2 * Math.atan(h / 2 / f)) / DEG;
  const fOf = (fov) => h / 2 / Math.tan((fov / 2) * DEG);
  // Never so narrow that the helicopter takes more than MAX_SHARE of the view's height, nor
  // narrower than FOV_MIN_DEG.
  const fMax = Math.min((MAX_SHARE * h) / (2 * tanRho), fOf(FOV_MIN_DEG));
  // The view whose edges, MARGIN_PX inside, hold the elevations lo to hi: its centre and
  // focal length (px), no narrower than allowed.
  const view = (lo, hi) => {
    const f = Math.max(1, h / 2 - MARGIN_PX) / Math.tan(Math.min(89.9, (hi - lo) / 2) * DEG);
    return { centre: (lo + hi) / 2, f: Math.min(f, fMax) };
  };
  // The helicopter's width in a view (wider off the centre), and a cue's height.
  const width = (v) => (2 * v.f * tanRho) / Math.cos((eHeli_deg - v.centre) * DEG);
  const tall = (v, [a, b]) => v.f * (Math.tan((b - v.centre) * DEG) - Math.tan((a - v.centre) * DEG));
  let lo = eHeli_deg - reach_deg, hi = eHeli_deg + reach_deg;
  const held = cues.map(() => false);
  cues.forEach((cue, k) => {
    const [a, b] = cue;
    const v = view(Math.min(lo, a), Math.max(hi, b));
    const before = (j) => Boolean(heldBefore[j]);
    const widest = before(k) ? fovMax_deg : fovMax_deg - FOV_SLACK_DEG;
    const withIt = held.map((x, j) => x || j === k);
    const allBefore = withIt.every((x, j) => !x || before(j));
    const least = allBefore ? MIN_HELI_PX - HOLD_SLACK_PX : MIN_HELI_PX;
    // The cue, and every cue held already, still tall enough in the wider view.
    const tallEnough = withIt.every((x, j) => !x || tall(v, cues[j]) >= (cues[j][2] || 0));
    if (fovOf(v.f) > widest || width(v) < least || !tallEnough) return;
    lo = Math.min(lo, a);
    hi = Math.max(hi, b);
    held[k] = true;
  });
  // With no cue, the helicopter alone, centred, TARGET_HELI_PX across.
  const v = held.some((x) => x) ? view(lo, hi) : { centre: eHeli_deg, f: Math.min(TARGET_HELI_PX / (2 * tanRho), fMax) };
  const fov_deg = Math.min(fovMax_deg, fovOf(v.f));
  return { centre_deg: v.centre, fov_deg, held, heli_px: width({ centre: v.centre, f: fOf(fov_deg) }) };
}

// The attitude (roll, pitch, yaw; body to NED, ZYX) as a three.js quaternion of the
// helicopter's group: P R Pᵀ, P the NED-to-three.js axes (also FRD to the group's axes).
export function attitude([phi, theta, psi]) {
  const cf = Math.cos(phi), sf = Math.sin(phi), ct = Math.cos(theta), st = Math.sin(theta);
  const cp = Math.cos(psi), sp = Math.sin(psi);
  const R = [
    [ct * cp, sf * st * cp - cf * sp, cf * st * cp + sf * sp],
    [ct * sp, sf * st * sp + cf * cp, cf * st * sp - sf * cp],
    [-st, sf * ct, cf * ct],
  ];
  const P = [[0, 1, 0], [0, 0, -1], [-1, 0, 0]];
  const M = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
  for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) {
    let s = 0;
    for (let k = 0; k < 3; k++) for (let l = 0; l < 3; l++) s += P[i][k] * R[k][l] * P[j][l];
    M[i][j] = s;
  }
  const m4 = new THREE.Matrix4().set(
    M[0][0], M[0][1], M[0][2], 0, M[1][0], M[1][1], M[1][2], 0, M[2][0], M[2][1], M[2][2], 0, 0, 0, 0, 1);
  return new THREE.Quaternion().setFromRotationMatrix(m4);
}

export class HeliView {
  // A view on `canvas`, or null where WebGL is not to be had. Options: camera ("pilot",
  // "chase", "top": the whole canvas), inset ({camera, x, y, w, h}: a second camera in a
  // rectangle of the canvas, px from its top left — one WebGL context draws both, as two
  // contexts cost a software renderer half its frame rate), pilotNE ([m north, m east] of the
  // take-off point where the pilot stands), flapScale (the disk's tilt drawn this many times
  // its size).
  static async create(canvas, opts) {
    let renderer;
    try {
      renderer = new THREE.WebGLRenderer({ canvas, antialias: false, powerPreference: "high-performance" });
    } catch (e) {
      console.warn("no WebGL: the flat view stays", e);
      return null;
    }
    // {parts, bounds_frd_m: [least, most], rotor_diameter_m}: heli_types::shape.
    const shape = await (await fetch("xcell60.json")).json();
    return new HeliView(canvas, renderer, shape, opts || {});
  }

  constructor(canvas, renderer, shape, opts) {
    this.canvas = canvas;
    this.renderer = renderer;
    this.opts = opts;
    this.pilotNE = opts.pilotNE || PILOT_DEFAULT_NE;
    // Whether the cameras frame the ground cues with the helicopter (false: the helicopter
    // alone, zoomed, at any height).
    this.frameGround = opts.frameGround !== false;
    // Drawn at `resolution` of the canvas's size and scaled up (a software renderer's time
    // goes with the pixels it fills); sizes and rectangles here are the canvas's own. With
    // `adaptive`, the resolution is where it starts, and the drawing's share then follows
    // the frame rate (between MIN_RESOLUTION and the whole canvas).
    const size = { w: canvas.width, h: canvas.height };
    this.size = size;
    this.adaptive = Boolean(opts.adaptive);
    this.ratio = this.adaptive ? Math.min(1, opts.resolution || 1) : opts.resolution || 1;
    this.ratioSince = null;
    this.ratioFrames = 0;
    this.ratioVotes = 0;
    renderer.setPixelRatio(this.ratio);
    renderer.setSize(size.w, size.h, true);
    this.scene = new THREE.Scene();
    this.scene.fog = new THREE.Fog(SKY_HORIZON, 200, 3000);
    const shot = (camera, rect) => {
      const cam = new THREE.PerspectiveCamera(45, rect.w / rect.h, 0.1, 4000);
      cam.layers.enableAll();
      return { camera, rect, cam };
    };
    // The shots: the whole canvas, and the inset if any.
    this.shots = [shot(opts.camera || "pilot", { x: 0, y: 0, w: size.w, h: size.h })];
    if (opts.inset) {
      const { x, y, w, h } = opts.inset;
      this.shots.push(shot(opts.inset.camera || "chase", { x, y, w, h }));
    }
    this.frameTimes = [];
    this.latencies = [];
    this.spin = 0;
    this.lastRenderMs = null;
    buildWorld(this);
    buildHeli(this, shape);
  }

  // Places the pilot `ne` ([m north, m east]) from the take-off point.
  placePilot(ne) { this.pilotNE = ne; }

  // Frames the ground cues with the helicopter (true) or the helicopter alone (false).
  setFrameGround(on) { this.frameGround = Boolean(on); }

  // Sets the camera of shot `index` (0: the whole canvas, 1: the inset).
  setCamera(kind, index) { const s = this.shots[index || 0]; if (s) s.camera = kind; }

  // Draws `state` (NED, from the simulator or the estimate). `home` is the take-off point
  // ([n, e, d]; the ground is at its d). `timing.produced_ms`: when the state shown was
  // produced (Date.now() clock), for the latency.
  render(state, history, plan, home, timing) {
    const now = performance.now();
    this.frameTimes.push(now);
    while (this.frameTimes.length && now - this.frameTimes[0] > 1000) this.frameTimes.shift();
    this.adapt(now);
    const dt = this.lastRenderMs === null ? 0 : Math.min(0.1, (now - this.lastRenderMs) / 1000);
    this.lastRenderMs = now;
    home = home || [0, 0, 0];
    const ground = home[2];
    const pos = ned3(state.pos_ned_m[0], state.pos_ned_m[1], state.pos_ned_m[2]);
    // Heights are drawn from the ground at the take-off point.
    const origin = ned3(home[0], home[1], ground);
    this.field.position.copy(origin);
    this.ground.position.set(origin.x, origin.y, origin.z);
    this.stand.position.copy(ned3(this.pilotNE[0], this.pilotNE[1], -0.02));
    this.heli.position.copy(pos);
    this.heli.quaternion.copy(state.quaternion || attitude(state.euler_rad));
    const k = this.opts.flapScale || 1;
    const [a1, b1] = state.flap_rad ? [state.flap_rad[0] * k, state.flap_rad[1] * k] : [0, 0];
    this.mainRotor.rotation.set(a1, 0, -b1);
    // The blades turn at the rotor's speed as a blur would show it (no frame rate can follow
    // 1600 rpm: a slow turn that stops with the rotor).
    const turning = state.rotor_rpm === undefined ? 1 : Math.min(1, state.rotor_rpm / 1000);
    this.spin += dt * 2 * Math.PI * 3.3 * turning;
    for (const s of this.spinners) {
      const angle = (s.userData.axis === "x" ? 3 : 1) * this.spin;
      if (s.userData.axis === "x") s.rotation.set(angle, 0, 0); else s.rotation.set(0, angle, 0);
    }
    // The wind sock: downwind, up with the wind.
    const w = state.wind_ned_mps || [0, 0, 0];
    const speed = Math.hypot(w[0], w[1]);
    const droop = 80 * DEG * Math.max(0, 1 - speed / 8);
    // three.js +z is south; the sock (along +z) turned to point where the air goes.
    const heading = speed > 0.05 ? Math.atan2(w[1], -w[0]) : 0;
    this.sockPivot.rotation.order = "YXZ";
    this.sockPivot.rotation.set(droop, heading, 0);
    this.updatePlan(plan || [], home);
    this.updateTrail(history || []);
    this.heli.updateMatrixWorld(true);
    const flatten = shadowMatrix(SUN, origin.y + 0.015);
    for (const s of this.shadows) s.matrix.multiplyMatrices(flatten, s.userData.of.matrixWorld);
    const H = this.size.h;
    this.renderer.setScissorTest(true);
    for (const [k, shot] of this.shots.entries()) {
      const { x, y, w, h } = shot.rect;
      if (k > 0) {
        // The inset's frame.
        this.renderer.setViewport(x - 2, H - y - h - 2, w + 4, h + 4);
        this.renderer.setScissor(x - 2, H - y - h - 2, w + 4, h + 4);
        this.renderer.setClearColor(0x0b0e12, 1);
        this.renderer.clear();
      }
      this.renderer.setViewport(x, H - y - h, w, h);
      this.renderer.setScissor(x, H - y - h, w, h);
      this.place(shot, pos, origin, state);
      this.sky.position.copy(shot.cam.position);
      this.labels.face(shot.cam);
      this.renderer.render(this.scene, shot.cam);
    }
    this.renderer.setScissorTest(false);
    if (timing && timing.produced_ms) {
      this.latencies.push([now, Date.now() - timing.produced_ms]);
      while (this.latencies.length && now - this.latencies[0][0] > 1000) this.latencies.shift();
    }
    return this.shots.map((shot) => this.stats(shot, pos, origin));
  }

  // Once a second, with a whole second drawn at the present resolution: the share of the
  // canvas's pixels drawn down where the frame rate fell under TARGET_FPS (twice running),
  // up a step where it has room for it (three times running).
  adapt(now) {
    if (!this.adaptive) return;
    if (this.ratioSince === null) {
      [this.ratioSince, this.ratioFrames] = [now, 0];
      return;
    }
    this.ratioFrames++;
    if (now - this.ratioSince < 1000) return;
    const fps = (1000 * this.ratioFrames) / (now - this.ratioSince);
    let want = this.ratio;
    if (fps < TARGET_FPS && this.ratio > MIN_RESOLUTION) {
      this.ratioVotes = Math.min(0, this.ratioVotes) - 1;
      if (this.ratioVotes <= -2) want = this.ratio * Math.sqrt(Math.max(1, fps) / FPS_AIM);
    } else if (fps >= RAISE_FPS_AT && this.ratio < 1) {
      this.ratioVotes = Math.max(0, this.ratioVotes) + 1;
      if (this.ratioVotes >= 3) want = this.ratio * RAISE_STEP;
    } else {
      this.ratioVotes = 0;
    }
    [this.ratioSince, this.ratioFrames] = [now, 0];
    want = Math.min(1, Math.max(MIN_RESOLUTION, Math.round(want * 100) / 100));
    if (want !== this.ratio) {
      this.ratio = want;
      this.ratioVotes = 0;
      this.renderer.setPixelRatio(want);
      this.renderer.setSize(this.size.w, this.size.h, true);
    }
  }

  updatePlan(plan, home) {
    const key = JSON.stringify(plan) + home.join(",");
    if (key === this.planKey) return;
    this.planKey = key;
    const points = plan.map((q) => ned3(home[0] + q.point[0], home[1] + q.point[1], home[2] - q.point[2]));
    this.plan.geometry.dispose();
    this.plan.geometry = new THREE.BufferGeometry().setFromPoints(points);
    this.plan.computeLineDistances();
  }

  updateTrail(history) {
    const pts = history.filter((s) => s.pos_ned_m);
    const n = Math.min(pts.length, this.trailPositions.length / 3);
    const first = pts.length - n;
    for (let i = 0; i < n; i++) {
      const p = pts[first + i].pos_ned_m;
      this.trailPositions[3 * i] = p[1];
      this.trailPositions[3 * i + 1] = -p[2];
      this.trailPositions[3 * i + 2] = -p[0];
    }
    this.trail.geometry.setDrawRange(0, n);
    this.trail.geometry.attributes.position.needsUpdate = true;
  }

  // The camera for this frame. Each camera turns to the helicopter and frames it with the
  // ground cues a pilot flies by — its shadow and the horizon — where they fit: the view
  // widens to take them in (the helicopter then above or below the centre), but never so far
  // that the helicopter is under MIN_HELI_PX across on screen (nor so narrow that it is more
  // than MAX_SHARE of the view). Where they do not fit, the view zooms on the helicopter
  // alone, centred, TARGET_HELI_PX across. The fit is reckoned in screen pixels, through the
  // perspective (a thing off the centre is drawn larger): a cue fits where the view that
  // holds it and the helicopter, MARGIN_PX inside its edges, still draws the helicopter
  // MIN_HELI_PX across.
  place(shot, pos, origin, state) {
    const cam = shot.cam;
    let eye, fovMax = FOV_MAX_DEG;
    if (shot.camera === "chase") {
      // Behind along the heading (the yaw only: a roll does not whip the camera round).
      const yaw = state.euler_rad[2];
      eye = pos.clone().add(new THREE.Vector3(-Math.sin(yaw), 0, Math.cos(yaw)).multiplyScalar(CHASE_BACK_M));
      eye.y = Math.max(eye.y + CHASE_UP_M, origin.y + 0.6);
      fovMax = CHASE_FOV_MAX_DEG;
    } else if (shot.camera === "top") {
      cam.position.set(pos.x, Math.max(pos.y, origin.y) + 30, pos.z);
      cam.up.set(0, 0, -1); // north up
      cam.lookAt(pos.x, pos.y, pos.z);
      this.setFov(cam, 40);
      shot.frame = null;
      return;
    } else {
      // The pilot: eyes 1.7 m up where the pilot stands.
      eye = origin.clone().add(ned3(this.pilotNE[0], this.pilotNE[1], -PILOT_EYE_M));
    }
    cam.position.copy(eye);
    cam.up.set(0, 1, 0);
    const to = pos.clone().sub(eye);
    const flat = Math.max(0.01, Math.hypot(to.x, to.z));
    const range = Math.max(0.3, to.length());
    const elev = (dy, d) => Math.atan2(dy, Math.max(0.01, d)) / DEG;
    // The helicopter's size for the framing: its rotor, the span seen from any side; its
    // reach, the farthest corner of its box from its centre.
    const rho = Math.atan(this.rotor_m / 2 / range) / DEG;
    const reach = Math.atan(Math.max(this.rotor_m / 2, this.reach_m) / range) / DEG;
    const eHeli = elev(to.y, flat);
    // The shadow in the vertical plane of the view (it may lie to one side of the
    // helicopter): from its near edge to its far, a rotor's length apart on the ground, worth
    // framing where that is SHADOW_LEAST_PX tall or more — and not at all where part of it is
    // behind the eye or under it.
    const azimuth = Math.atan2(to.x, -to.z);
    const shadow = this.shadowPoint(pos, origin).sub(eye);
    const ahead = shadow.x * Math.sin(azimuth) - shadow.z * Math.cos(azimuth);
    const r = this.rotor_m / 2;
    const shadowCue = ahead - r > 0.01
      ? [elev(shadow.y, ahead - r), elev(shadow.y, ahead + r), SHADOW_LEAST_PX]
      : [-90, -90, Infinity];
    const eHorizon = elev(origin.y - eye.y, 2000);
    const cues = this.frameGround ? [shadowCue, [eHorizon, eHorizon]] : [];
    const frame = frameCues(shot.rect.h, fovMax, eHeli, rho, cues, shot.frame ? shot.frame.held : [], reach);
    shot.frame = frame;
    const c = frame.centre_deg * DEG;
    cam.lookAt(eye.x + Math.sin(azimuth) * Math.cos(c), eye.y + Math.sin(c), eye.z - Math.cos(azimuth) * Math.cos(c));
    this.setFov(cam, frame.fov_deg);
  }

  setFov(cam, fov) {
    if (cam.fov !== fov) {
      cam.fov = fov;
      cam.updateProjectionMatrix();
    }
    cam.updateMatrixWorld(true);
  }

  // Where the helicopter's shadow falls (three.js axes).
  shadowPoint(pos, origin) {
    const up = pos.y - origin.y;
    return new THREE.Vector3(pos.x - SUN.x * up / SUN.y, origin.y, pos.z - SUN.z * up / SUN.y);
  }

  // What is on the canvas: the helicopter's size (px, its box's extent), its shadow and
  // the horizon in view, frames a second, the state-to-frame latency (ms, the last second's
  // mean).
  stats(shot, pos, origin) {
    const cam = shot.cam;
    const { w, h } = shot.rect;
    const toScreen = (v) => {
      const p = v.clone().project(cam);
      return [(p.x + 1) * w / 2, (1 - p.y) * h / 2, p.z];
    };
    let [x0, y0, x1, y1] = [Infinity, Infinity, -Infinity, -Infinity];
    for (const c of this.corners) {
      const [x, y] = toScreen(c.clone().applyMatrix4(this.heli.matrixWorld));
      x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y);
    }
    const [hx, hy, hz] = toScreen(pos);
    const heliOnScreen = hz < 1 && hx >= 0 && hx <= w && hy >= 0 && hy <= h;
    const [sx, sy, sz] = toScreen(this.shadowPoint(pos, origin));
    const shadowOnScreen = sz < 1 && sx >= 0 && sx <= w && sy >= 0 && sy <= h;
    // The horizon straight ahead: a point on the ground far away under the view's centre.
    const ahead = new THREE.Vector3();
    cam.getWorldDirection(ahead);
    ahead.y = 0;
    let horizonInView = false;
    if (ahead.lengthSq() > 1e-6) {
      ahead.normalize().multiplyScalar(1500).add(cam.position);
      ahead.y = origin.y;
      const [, ay, az] = toScreen(ahead);
      horizonInView = az < 1 && ay >= 0 && ay <= h;
    }
    const latency = this.latencies.length
      ? this.latencies.reduce((s, [, l]) => s + l, 0) / this.latencies.length : null;
    return {
      camera: shot.camera,
      heliOnScreen,
      heliPx: heliOnScreen ? Math.max(x1 - x0, y1 - y0) : 0,
      heliXY: [hx, hy],
      shadowOnScreen,
      horizonInView,
      fov_deg: cam.fov,
      // The framing's ground cues held ([shadow, horizon]) and the helicopter's planned
      // width (px).
      cues_framed: shot.frame ? shot.frame.held : null,
      planned_heli_px: shot.frame ? shot.frame.heli_px : null,
      range_m: cam.position.distanceTo(pos),
      fps: this.frameTimes.length,
      latency_ms: latency,
      resolution: this.ratio,
    };
  }

  // Counts the rendered pixels of each thing on the canvas's view (the last frame's
  // camera): the helicopter (its pixels' bounding box: px across), its shadow, the sky and
  // the ground. Rendered off screen, one layer at a time.
  measure(index) {
    const shot = this.shots[index || 0];
    const cam = shot.cam;
    const w = Math.round(shot.rect.w * this.ratio), h = Math.round(shot.rect.h * this.ratio);
    const target = new THREE.WebGLRenderTarget(w, h);
    const pixels = new Uint8Array(4 * w * h);
    const clear = new THREE.Color();
    this.renderer.getClearColor(clear);
    const alpha = this.renderer.getClearAlpha();
    this.renderer.setClearColor(0x000000, 0);
    const count = (layer) => {
      cam.layers.set(layer);
      this.renderer.setRenderTarget(target);
      this.renderer.setViewport(0, 0, shot.rect.w, shot.rect.h);
      this.renderer.clear();
      this.sky.position.copy(cam.position);
      this.renderer.render(this.scene, cam);
      this.renderer.readRenderTargetPixels(target, 0, 0, w, h, pixels);
      let n = 0, x0 = w, y0 = h, x1 = -1, y1 = -1;
      for (let y = 0; y < h; y++) for (let x = 0; x < w; x++) {
        if (pixels[4 * (y * w + x) + 3] === 0) continue;
        n++;
        if (x < x0) x0 = x; if (x > x1) x1 = x; if (y < y0) y0 = y; if (y > y1) y1 = y;
      }
      // In the canvas's pixels (as on screen), not the drawing's.
      const across = n ? Math.max(x1 - x0 + 1, y1 - y0 + 1) / this.ratio : 0;
      return { pixels: Math.round(n / this.ratio / this.ratio), across_px: Math.round(across) };
    };
    const out = {
      heli: count(LAYER.heli),
      shadow: count(LAYER.shadow),
      sky: count(LAYER.sky),
      ground: count(LAYER.ground),
    };
    this.renderer.setRenderTarget(null);
    this.renderer.setClearColor(clear, alpha);
    cam.layers.enableAll();
    target.dispose();
    // The ground's edge in view: ground, and at least a row of sky above it.
    out.horizon = out.ground.pixels > 0 && out.ground.pixels <= shot.rect.w * (shot.rect.h - 1);
    return out;
  }
}

// States as they arrive, shown a little later and interpolated, so that the view moves
// smoothly at the display's rate between the simulator's frames (30 a second).
export class StateBuffer {
  constructor() { this.frames = []; this.lag = []; }

  // A state produced at `produced_ms` (Date.now() clock).
  push(state, produced_ms) {
    const arrived = Date.now();
    const last = this.frames[this.frames.length - 1];
    if (last && produced_ms <= last.produced) {
      if (produced_ms < last.produced - 1000) this.frames = []; // a new run
      else return;
    }
    this.frames.push({ state, produced: produced_ms, q: attitude(state.euler_rad) });
    while (this.frames.length > 30) this.frames.shift();
    this.lag.push(Math.max(0, arrived - produced_ms));
    while (this.lag.length > 30) this.lag.shift();
  }

  // The state to draw now, and when it was produced: a frame period and the recent arrival
  // lag behind the newest, interpolated (position linearly, attitude along the great circle).
  now() {
    const sorted = [...this.lag].sort((a, b) => a - b);
    const lag = sorted[Math.floor(0.9 * (sorted.length - 1))] || 0;
    return this.at(Date.now() - lag - 40);
  }

  // The state as it was at `at` (Date.now() clock), between the two states around it; the
  // first or the newest outside them.
  at(at) {
    const f = this.frames;
    if (!f.length) return null;
    let i = f.length - 1;
    while (i > 0 && f[i - 1].produced > at) i--;
    const b = f[i], a = f[i - 1];
    if (!a || at >= b.produced) return { state: { ...b.state, quaternion: b.q }, produced_ms: b.produced };
    if (at <= a.produced) return { state: { ...a.state, quaternion: a.q }, produced_ms: a.produced };
    const u = (at - a.produced) / (b.produced - a.produced);
    const mix = (p, q) => (p && q ? p.map((v, k) => v + (q[k] - v) * u) : q);
    const state = { ...b.state };
    for (const key of ["pos_ned_m", "vel_ned_mps", "flap_rad", "wind_ned_mps"]) state[key] = mix(a.state[key], b.state[key]);
    state.quaternion = a.q.clone().slerp(b.q, u);
    return { state, produced_ms: a.produced + u * (b.produced - a.produced) };
  }
}
