"""A stand-in for viser's browser client that clicks scene nodes, for tests of the 3D view.

It speaks viser's own wire protocol, with viser's own message classes: a websocket with the
``viser-v<version>`` subprotocol, a camera message first (viser counts a client as connected
only from its first camera message), then :class:`SceneNodeClickMessage` as the browser sends
it when a clickable node is clicked. The server dispatches it to the node's ``on_click``
callbacks exactly as it dispatches a real click. Keep the connection open until the click has
been seen: viser drops a click whose client is gone before the click is handled.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager

import msgspec.msgpack
import viser
from viser import _messages  # the wire protocol's message classes
from websockets.sync.client import connect
from websockets.sync.connection import Connection
from websockets.typing import Subprotocol

Vec3 = tuple[float, float, float]


class ViserClient:
    def __init__(self, ws: Connection) -> None:
        self._ws = ws

    def _send(self, message: _messages.Message) -> None:
        self._ws.send(msgspec.msgpack.encode(message.as_serializable_dict()))

    def move_camera(self, position: Vec3, look_at: Vec3) -> None:
        """Where the user has turned the camera (the browser reports it as it moves)."""
        self._send(_camera_message(position, look_at))

    def click(
        self,
        name: str,
        *,
        instance_index: int | None = None,
        ray_origin: Sequence[float] = (0.0, 0.0, 2.0),
        ray_direction: Sequence[float] = (0.0, 0.0, -1.0),
    ) -> None:
        """Click scene node ``name`` (instance ``instance_index`` of a batch, or whatever the ray
        hits when None)."""
        origin: Vec3 = (float(ray_origin[0]), float(ray_origin[1]), float(ray_origin[2]))
        direction: Vec3 = (
            float(ray_direction[0]),
            float(ray_direction[1]),
            float(ray_direction[2]),
        )
        self._send(
            _messages.SceneNodeClickMessage(
                name=name,
                instance_index=instance_index,
                ray_origin=origin,
                ray_direction=direction,
                screen_pos=(0.5, 0.5),
                modifier=None,
            )
        )


@contextmanager
def viser_client(url: str) -> Iterator[ViserClient]:
    """A connected client of the viser view at ``url`` (``http://host:port``, viser's own or
    the dashboard's gate in front of it)."""
    ws_url = "ws" + url.removeprefix("http").rstrip("/") + "/"
    with connect(
        ws_url,
        subprotocols=[Subprotocol(f"viser-v{viser.__version__}")],
        max_size=None,  # the scene is sent on connecting: tens of MB
        max_queue=None,  # keep reading it, so the server never waits on this client
        compression=None,
        open_timeout=10,
    ) as ws:
        client = ViserClient(ws)
        client._send(_camera_message((0.0, 0.0, 3.0), (0.0, 0.0, 0.0)))
        yield client


def _camera_message(position: Vec3, look_at: Vec3) -> _messages.ViewerCameraMessage:
    return _messages.ViewerCameraMessage(
        wxyz=(1.0, 0.0, 0.0, 0.0),
        position=position,
        fov=1.0,
        near=0.01,
        far=100.0,
        image_height=480,
        image_width=640,
        look_at=look_at,
        up_direction=(0.0, 0.0, 1.0),
    )
