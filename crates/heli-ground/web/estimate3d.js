// The display's 3D view of the vehicle's estimate (telemetry, never the simulator's truth),
// drawn by the same renderer as the simulator's view (view3d.js): the chase camera behind the
// estimated helicopter. instruments.js hands it each telemetry row; where WebGL is not to be
// had, instruments.js draws its flat view instead.
import { HeliView } from "./view3d.js";

const canvas = document.getElementById("view3d");
if (canvas) {
  // Drawn whole where the machine keeps 30 frames a second, else at the share that does.
  HeliView.create(canvas, { camera: "chase", adaptive: true })
    .then((view) => {
      if (view) window.heliEstimateView = view;
      else window.heliEstimateFlat = true;
    })
    .catch(() => { window.heliEstimateFlat = true; });
}
