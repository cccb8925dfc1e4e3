"""The live fan-out: bounded per-client queues, lagging clients told to resynchronise."""

from __future__ import annotations

import asyncio
import threading

from app.hub import Ended, EventHub, Lagged


def _events(first: int, n: int) -> list[dict[str, object]]:
    return [{"type": "node_visited", "seq": s} for s in range(first, first + n)]


def test_a_slow_client_is_told_to_resync_and_others_are_not_held_back() -> None:
    async def scenario() -> None:
        hub = EventHub(client_limit=10)
        hub.open("r")
        hub.publish("r", _events(0, 3))
        got = hub.subscribe("r", after=0)
        assert got is not None
        backlog, slow = got
        assert [e["seq"] for e in backlog] == [1, 2]
        _, fast = hub.subscribe("r") or ([], None)  # type: ignore[assignment]
        assert fast is not None
        seen: list[int] = []
        for first in range(3, 23, 4):  # 20 events from another thread, in batches of 4
            thread = threading.Thread(target=hub.publish, args=("r", _events(first, 4)))
            thread.start()
            thread.join()
            await asyncio.sleep(0)
            while not fast.queue.empty():  # the fast client keeps up
                item = await fast.get()
                assert isinstance(item, list)
                seen += [int(e["seq"]) for e in item]  # type: ignore[call-overload]
        assert seen == list(range(3, 23))
        assert isinstance(await slow.get(), Lagged)  # dropped, told to resync
        assert slow.queue.empty()
        hub.end("r", "solved")
        await asyncio.sleep(0)
        item = await fast.get()
        assert isinstance(item, Ended) and item.status == "solved"
        assert hub.events("r") is None and not hub.is_live("r")

    asyncio.run(scenario())


def test_events_of_a_live_run_are_kept_until_it_ends() -> None:
    hub = EventHub()
    hub.open("r")
    seen: list[tuple[str, int]] = []
    hub.add_listener(lambda run_id, events: seen.append((run_id, len(events))))
    hub.publish("r", _events(0, 5))
    hub.publish("other", _events(0, 5))  # not live: dropped with a warning
    assert [e["seq"] for e in hub.events("r", after=2) or []] == [3, 4]
    assert seen == [("r", 5)]
