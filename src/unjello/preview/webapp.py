"""The preview's web page and its JSON/PNG API (Starlette), over one :class:`PreviewClip`.

Routes (every query takes the settings ``method``, ``readout``, ``direction``,
``reference``, ``camera_only``; those not given are the clip's starting ones):

- ``GET /`` -- the page (``preview/page.html``);
- ``GET /api/info`` -- the clip: frames, size, rate, starting settings, where the readout
  came from;
- ``GET /api/frame/{n}.png?view=input|corrected`` -- frame ``n`` as read or corrected;
  the header ``X-Render-Seconds`` says how long the correction took;
- ``GET /api/motion.png?frame=n`` -- the motion of the frames corrected so far with these
  settings, frame ``n`` marked;
- ``GET /api/command`` -- ``{"command": "unjello correct ..."}`` for these settings;
- ``GET /api/preset.json`` -- these settings as a preset file.

Only the clip the server was started with is served: no path from a request is opened.
A bad request is answered ``400`` (an unknown page ``404``) with ``{"error": "..."}`` (one
line, as the command line says it); anything else that goes wrong is ``500`` with its
message, and the server goes on.
"""

from __future__ import annotations

import io
from importlib import resources

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, Response
from starlette.routing import Route

from ..errors import UnjelloError
from ..exports.outputs import plot_trajectory
from .clip import PreviewClip, PreviewSettings, encode_png

__all__ = ["create_app"]


def create_app(clip: PreviewClip) -> Starlette:
    """Return the web app that previews ``clip``."""
    page = resources.files("unjello.preview").joinpath("page.html").read_text("utf-8")

    def settings(request: Request) -> PreviewSettings:
        return PreviewSettings.from_query(request.query_params, clip.initial)

    def frame_number(text: str) -> int:
        try:
            return int(text)
        except ValueError:
            raise UnjelloError(f"frame must be a whole number, not {text!r}") from None

    async def index(request: Request) -> Response:
        return HTMLResponse(page)

    def info(request: Request) -> Response:
        return JSONResponse(clip.info())

    def frame(request: Request) -> Response:
        n = frame_number(request.path_params["n"])
        view = request.query_params.get("view", "corrected")
        if view == "input":
            return Response(encode_png(clip.frame(n)), media_type="image/png")
        if view != "corrected":
            raise UnjelloError(f"view must be input or corrected, not {view!r}")
        image, seconds = clip.corrected(n, settings(request))
        return Response(encode_png(image), media_type="image/png",
                        headers={"X-Render-Seconds": f"{seconds:.3f}",
                                 "Cache-Control": "no-store"})

    def motion(request: Request) -> Response:
        chosen = settings(request)
        n = frame_number(request.query_params.get("frame", "0"))
        traj = clip.motions(chosen)
        if not len(traj):
            clip.corrected(n, chosen)
            traj = clip.motions(chosen)
        png = io.BytesIO()
        plot_trajectory(traj, png, mark=float(n))
        return Response(png.getvalue(), media_type="image/png",
                        headers={"Cache-Control": "no-store"})

    def command(request: Request) -> Response:
        return JSONResponse({"command": clip.command(settings(request))})

    def preset(request: Request) -> Response:
        return Response(clip.preset(settings(request)), media_type="application/json",
                        headers={"Content-Disposition":
                                 'attachment; filename="unjello_preset.json"'})

    def guarded(handler):  # type: ignore[no-untyped-def]
        def run(request: Request) -> Response:
            try:
                return handler(request)
            except UnjelloError as exc:
                return JSONResponse({"error": str(exc)}, status_code=400)
            except Exception as exc:  # the server goes on; the page says what happened
                return JSONResponse({"error": f"{type(exc).__name__}: {exc}"},
                                    status_code=500)
        return run

    routes = [Route("/", index),
              Route("/api/info", guarded(info)),
              Route("/api/frame/{n}.png", guarded(frame)),
              Route("/api/motion.png", guarded(motion)),
              Route("/api/command", guarded(command)),
              Route("/api/preset.json", guarded(preset))]
    async def not_found(request: Request, exc: Exception) -> Response:
        return JSONResponse({"error": f"no such page: {request.url.path}"}, status_code=404)

    return Starlette(routes=routes, exception_handlers={404: not_found})
