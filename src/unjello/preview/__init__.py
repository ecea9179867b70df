"""``unjello preview``: a clip held for tuning by eye, and the local page that shows it.

:class:`PreviewClip` holds a clip's frames and corrects one frame at a time with the
settings of the page's controls; :func:`create_app` is the page's web application
(Starlette, on 127.0.0.1 only), served by the command line.
"""

from .clip import PREVIEW_METHODS, PreviewClip, PreviewSettings, encode_png
from .webapp import create_app

__all__ = ["PREVIEW_METHODS", "PreviewClip", "PreviewSettings", "encode_png", "create_app"]
