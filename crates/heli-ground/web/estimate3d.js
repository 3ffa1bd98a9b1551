// The display's 3D view of the vehicle's estimate (telemetry, never the simulator's truth),
// drawn by the same renderer as the simulator's view (view3d.js): the chase camera behind the
// estimated helicopter. instruments.js hands it each telemetry row; where WebGL is not to be
// had, instruments.js draws its flat view instead.
import { HeliView } from "./view3d.js";

const canvas = document.getElementById("view3d");
if (canvas) {
  // Drawn whole, not adapted: it is drawn when a telemetry view arrives (10 a second), not on
  // every animation frame, so its frame count says nothing of the machine.
  HeliView.create(canvas, { camera: "chase" })
    .then((view) => {
      if (view) window.heliEstimateView = view;
      else window.heliEstimateFlat = true;
    })
    .catch(() => { window.heliEstimateFlat = true; });
}
