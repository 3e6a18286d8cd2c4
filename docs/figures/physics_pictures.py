"""Pictures of the physics scene for docs/physics.md: the Panda and the human carrying.

    MUJOCO_GL=egl python docs/figures/physics_pictures.py [--out docs/figures]

Puts the object in a carried state (held by both), with the human's embodied hand on its
handle, and renders it with the backend's offscreen renderer (a camera closer than the
env's default, aimed at the two hands).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import imageio.v3 as iio
import numpy as np

from hri_envs.envs.config import scenario_graph
from hri_envs.physics import PandaSim
from hri_envs.physics.scene.rendering import SceneRenderer

# scenario -> (state, camera azimuth [deg], elevation [deg], distance [m])
SHOTS = {
    "hanger": ("held at B′ column, 0.87 m, rail-facing", 150.0, -20.0, 1.5),
    "wheel": ("held at A column, 1.3 m, vertical", 140.0, -18.0, 2.6),
}


def main() -> None:
    """Render one picture per scenario into --out."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/figures")
    args = parser.parse_args()
    for name, (state_name, azimuth, elevation, distance) in SHOTS.items():
        g = scenario_graph(name)
        state = g.state_names.index(state_name)
        sim = PandaSim(g)
        sim.reset(0, state=state)
        hands = (sim.data.site_xpos[sim.scene.grip_site] + sim.data.xpos[sim.arm.hand_body]) / 2
        camera = {"lookat": hands - np.array([0.0, 0.0, 0.1]), "azimuth": azimuth,
                  "elevation": elevation, "distance": distance}
        renderer = SceneRenderer(sim.model, sim.seats.pos, height=360, width=540,
                                 camera=camera, data=sim.data)
        path = Path(args.out) / f"physics_{name}.png"
        iio.imwrite(path, renderer.render(sim.data), optimize=True)
        renderer.close()
        print(f"wrote {path} ({path.stat().st_size // 1024} KB)")


if __name__ == "__main__":
    main()
