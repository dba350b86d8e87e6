"""Drawing the sagittal model with pymunk's pygame debug-draw utilities.

pymunk is used **only for drawing**: every segment is a kinematic ``pymunk.Body`` carrying
``pymunk.Segment`` (and, for the head, ``pymunk.Circle``) shapes in the segment frame; before each
frame the bodies are placed at the segment origins and global angles computed from the state with the
generated kinematics (:func:`sspinn.model.kinematics.point_kinematics`), and ``Space.debug_draw`` paints
them through ``pymunk.pygame_util.DrawOptions`` on an off-screen ``pygame.Surface``. The space is never
stepped; the physics is sspinn's.

World → screen: x forward, y up, ``pixels_per_metre`` pixels per metre; the camera follows the hip
horizontally and keeps the ground near the bottom edge (a ``pymunk.Transform`` with a y flip, so no
global ``positive_y_is_up`` switch is touched). Right leg red, left leg blue (as
:mod:`sspinn.model.drawing`), ground reaction forces as arrows at the contact points (right orange, left
green; ``grf_metres_per_bw`` metres per body weight), ground ticks every 0.5 m so forward motion is visible.

``human`` mode shows the frame in a pygame window; without ``DISPLAY``/``WAYLAND_DISPLAY`` the SDL
video and audio drivers are set to ``dummy`` first (the window then exists but is invisible), so the
mode also works headless (Gymnasium's ``check_env`` creates it). Only ``pygame.display.init()`` and
``pygame.font.init()`` are called, never ``pygame.init()`` (which would open the audio device).
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from sspinn.model import dynamics, kinematics
from sspinn.model.body import BodyParameters
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import SIDES

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")  # before the first pygame import

import pygame  # noqa: E402
import pymunk  # noqa: E402
import pymunk.pygame_util  # noqa: E402

_COLORS: dict[str, tuple[int, int, int, int]] = {
    "pelvis": (60, 60, 60, 255),
    "r": (214, 39, 40, 255),  # tab:red
    "l": (31, 119, 180, 255),  # tab:blue
    "ground": (90, 90, 90, 255),
    "grf_r": (255, 127, 14, 255),  # tab:orange
    "grf_l": (44, 160, 44, 255),  # tab:green
}
_BACKGROUND = (245, 245, 240)


def _headless() -> bool:
    return not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


class PymunkRenderer:
    """Off-screen (``rgb_array``) or windowed (``human``) drawing of one state.

    Args:
        body: body parameters (segment lengths, foot geometry).
        contact: contact parameters (for the contact-point position along the foot).
        width, height: image size, px.
        pixels_per_metre: drawing scale, px/m.
        grf_metres_per_bw: arrow length per body weight of ground reaction force, m/BW.
        mode: "rgb_array" or "human".
        fps: frame rate of the ``human`` window, frames/s.
    """

    def __init__(
        self,
        body: BodyParameters,
        contact: ContactParameters,
        *,
        width: int = 600,
        height: int = 400,
        pixels_per_metre: float = 190.0,
        grf_metres_per_bw: float = 0.5,
        mode: str = "rgb_array",
        fps: float = 100.0,
    ) -> None:
        if mode not in ("rgb_array", "human"):
            raise ValueError(f"render mode must be 'rgb_array' or 'human', got {mode!r}")
        self.body = body
        self.contact = contact
        self.width, self.height = int(width), int(height)
        self.scale = float(pixels_per_metre)
        self.grf_scale = float(grf_metres_per_bw)
        self.mode = mode
        self.fps = fps
        self._window: Any = None
        self._clock: Any = None
        if mode == "human":
            if _headless():
                os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
                os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
            pygame.display.init()
            self._window = pygame.display.set_mode((self.width, self.height))
            pygame.display.set_caption("sspinn SagittalWalker")
            self._clock = pygame.time.Clock()
        self.surface = pygame.Surface((self.width, self.height))
        self._font = self._make_font()
        self.space = pymunk.Space()
        self._bodies = self._build_bodies()
        self._options = pymunk.pygame_util.DrawOptions(self.surface)
        self._options.flags = pymunk.SpaceDebugDrawOptions.DRAW_SHAPES

    @staticmethod
    def _make_font() -> Any:
        try:
            pygame.font.init()
            return pygame.font.Font(None, 20)
        except (pygame.error, OSError):  # pragma: no cover - fonts are bundled with pygame wheels
            return None

    def _build_bodies(self) -> dict[str, pymunk.Body]:
        """Kinematic bodies with shapes in the segment frames (origin at the proximal joint)."""
        b = self.body
        radius = 0.022 * b.height / 1.75  # segment half-thickness, m
        bodies: dict[str, pymunk.Body] = {}

        def add(name: str, shapes: list[pymunk.Shape], color: tuple[int, int, int, int]) -> None:
            body = bodies[name]
            for shape in shapes:
                shape.color = color
            self.space.add(body, *shapes)

        # left leg first so that the right leg is drawn on top (the viewer stands at the right side)
        for side in reversed(SIDES):
            color = _COLORS[side]
            for seg in ("femur", "tibia"):
                name = f"{seg}_{side}"
                bodies[name] = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
                length = getattr(b, name).length
                add(name, [pymunk.Segment(bodies[name], (0, 0), (0, -length), radius)], color)
            name = f"foot_{side}"
            foot = getattr(b, name)
            bodies[name] = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            add(
                name,
                [
                    pymunk.Segment(bodies[name], (0, 0), foot.heel, radius * 0.8),
                    pymunk.Segment(bodies[name], foot.heel, foot.toe, radius * 0.8),
                    pymunk.Segment(bodies[name], foot.toe, (0, 0), radius * 0.8),
                ],
                color,
            )
        trunk = b.pelvis.length
        head = 0.065 * b.height
        bodies["pelvis"] = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        add(
            "pelvis",
            [
                pymunk.Segment(bodies["pelvis"], (0, 0), (0, trunk), radius * 1.6),
                pymunk.Circle(bodies["pelvis"], head, (0, trunk + 1.1 * head)),
            ],
            _COLORS["pelvis"],
        )
        bodies["ground"] = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        half = self.width / self.scale
        add("ground", [pymunk.Segment(bodies["ground"], (-half, -0.01), (half, -0.01), 0.01)], _COLORS["ground"])
        return bodies

    # ------------------------------------------------------------------------------------------
    def _to_screen(self, x: float, y: float, camera_x: float) -> tuple[int, int]:
        return (
            round(self.width / 2 + self.scale * (x - camera_x)),
            round(self.height - 0.08 * self.height - self.scale * y),
        )

    def draw(self, q: np.ndarray, u: np.ndarray, grf: np.ndarray, text: str = "") -> np.ndarray | None:
        """Draw state (q, u) with ground reaction forces ``grf`` (4,) in N; returns the frame as an
        (height, width, 3) uint8 array in ``rgb_array`` mode, None in ``human`` mode."""
        q = np.asarray(q, dtype=np.float64)
        w = dynamics.contact_fraction(q, self.contact)
        points = kinematics.point_kinematics(q, np.zeros(9), np.zeros(9), w, self.body)[:, :2]
        at = {name: points[kinematics.point_index(name)] for name in kinematics.POINTS}
        camera_x = float(q[0])
        angle = {"pelvis": q[2]}
        for k, side in enumerate(SIDES):
            hip, knee, ankle = q[3 + 3 * k : 6 + 3 * k]
            angle[f"femur_{side}"] = q[2] + hip
            angle[f"tibia_{side}"] = q[2] + hip + knee
            angle[f"foot_{side}"] = q[2] + hip + knee + ankle
        origin = {"pelvis": at["hip"]}
        for side in SIDES:
            origin[f"femur_{side}"] = at["hip"]
            origin[f"tibia_{side}"] = at[f"knee_{side}"]
            origin[f"foot_{side}"] = at[f"ankle_{side}"]
        for name, body in self._bodies.items():
            if name == "ground":
                body.position = (camera_x, 0.0)
                body.angle = 0.0
            else:
                body.position = (float(origin[name][0]), float(origin[name][1]))
                body.angle = float(angle[name])
            # the space is never stepped: refresh the shapes' cached world coordinates explicitly
            self.space.reindex_shapes_for_body(body)
        self.surface.fill(_BACKGROUND)
        # world → screen: scale, flip y, camera on the hip, ground 8 % above the bottom edge
        self._options.transform = pymunk.Transform(
            a=self.scale, b=0.0, c=0.0, d=-self.scale,
            tx=self.width / 2 - self.scale * camera_x, ty=self.height - 0.08 * self.height,
        )
        self._draw_ticks(camera_x)
        self.space.debug_draw(self._options)
        bw = self.body.body_weight
        for k, side in enumerate(SIDES):
            self._draw_arrow(at[f"contact_{side}"], grf[2 * k : 2 * k + 2] / bw, _COLORS[f"grf_{side}"], camera_x)
        if text and self._font is not None:
            self.surface.blit(self._font.render(text, True, (20, 20, 20)), (8, 6))
        if self.mode == "human":
            self._window.blit(self.surface, (0, 0))
            pygame.event.pump()
            pygame.display.flip()
            self._clock.tick(self.fps)
            return None
        return np.transpose(pygame.surfarray.array3d(self.surface), (1, 0, 2)).copy()

    def _draw_ticks(self, camera_x: float) -> None:
        half = 0.5 * self.width / self.scale
        for x in np.arange(math.floor((camera_x - half) * 2) / 2, camera_x + half + 0.5, 0.5):
            top = self._to_screen(float(x), 0.0, camera_x)
            pygame.draw.line(self.surface, (150, 150, 150), top, (top[0], top[1] + 8), 2 if x % 1 == 0 else 1)

    def _draw_arrow(self, start: np.ndarray, force_bw: np.ndarray, color: tuple[int, ...], camera_x: float) -> None:
        if force_bw[1] < 0.02:  # no (or negligible) contact
            return
        end = start + self.grf_scale * force_bw
        p0, p1 = self._to_screen(*start, camera_x), self._to_screen(*end, camera_x)
        rgb = color[:3]
        pygame.draw.line(self.surface, rgb, p0, p1, 3)
        d = np.subtract(p1, p0).astype(float)
        n = np.hypot(*d)
        if n < 4:
            return
        d /= n
        head = 9.0
        left = (p1[0] - head * d[0] + 0.5 * head * d[1], p1[1] - head * d[1] - 0.5 * head * d[0])
        right = (p1[0] - head * d[0] - 0.5 * head * d[1], p1[1] - head * d[1] + 0.5 * head * d[0])
        pygame.draw.polygon(self.surface, rgb, [p1, left, right])

    def close(self) -> None:
        """Close the window (``human`` mode); the off-screen surface needs no cleanup."""
        if self._window is not None:
            pygame.display.quit()
            self._window = None
