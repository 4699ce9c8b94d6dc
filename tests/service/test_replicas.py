"""Two uvicorn processes sharing one redis-server: a plan made on one is stepped on both, survives
the death of either, and concurrent steps on the two never lose or double a move."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.service.conftest import RedisServer, Replica, random_map, replicas

GRID = random_map(24, 24, 0.15, seed=3).tolist()


@pytest.fixture
def two(redis_server: RedisServer, tmp_path: Path) -> Iterator[list[Replica]]:
    with replicas(redis_server.url, tmp_path, 2) as started:
        yield started


def _client(replica: Replica) -> httpx.Client:
    return httpx.Client(base_url=replica.url, trust_env=False, timeout=60)


def _new_plan(client: httpx.Client) -> tuple[str, list[list[int]]]:
    r = client.post("/maps", json={"grid": GRID, "start": [0, 0], "goal": [23, 23]})
    assert r.status_code == 201, r.text
    plan = r.json()["plan"]
    return plan["plan_id"], plan["preview"]["path"]


def _step(client: httpx.Client, plan_id: str, seq: int | None) -> dict[str, Any]:
    body: dict[str, Any] = {"dynamic_obstacles": []} if seq is None else {"seq": seq}
    r = client.post(f"/plan/{plan_id}/step", json=body)
    assert r.status_code == 200, r.text
    answer: dict[str, Any] = r.json()
    return answer


def test_a_plan_is_stepped_on_both_replicas_and_outlives_one(two: list[Replica]) -> None:
    a, b = two
    with _client(a) as ca, _client(b) as cb:
        plan_id, path = _new_plan(ca)
        assert len(path) > 20
        answers: list[dict[str, Any]] = []
        for seq in range(len(path) - 1):
            here, there = (ca, cb) if seq % 2 == 0 or seq > 8 else (cb, ca)
            if seq == 9:
                a.kill()  # mid-episode: its last step (seq 8) is retried on b below
                assert cb.post(f"/plan/{plan_id}/step", json={"seq": 8}).json() == answers[-1]
            answer = _step(cb if seq > 8 else here, plan_id, seq)
            if seq <= 8:  # the same seq again on the other replica: the stored answer
                assert _step(there, plan_id, seq) == answer
            assert answer["seq"] == seq
            assert answer["iteration"] == seq + 1
            assert answer["previous"] == path[seq]
            assert answer["position"] == path[seq + 1]
            answers.append(answer)
        assert answers[-1]["status"] == "arrived"
        detail = cb.get(f"/plan/{plan_id}").json()
        assert detail["trajectory"] == path
        assert detail["iteration"] == len(path) - 1


def test_concurrent_steps_on_two_replicas_move_once_per_seq(two: list[Replica]) -> None:
    with _client(two[0]) as ca, _client(two[1]) as cb:
        plan_id, path = _new_plan(ca)

        def both(seq: int | None) -> list[dict[str, Any]]:
            barrier = threading.Barrier(2)
            answers: list[dict[str, Any]] = [{}, {}]

            def send(i: int, client: httpx.Client) -> None:
                barrier.wait()
                answers[i] = _step(client, plan_id, seq)

            threads = [threading.Thread(target=send, args=(i, c)) for i, c in enumerate((ca, cb))]
            for t in threads:
                t.start()
            for t in threads:
                t.join(timeout=120)
            return answers

        for seq in range(6):  # the same seq sent to both at once: one moves, one replays
            first, second = both(seq)
            assert first == second
            assert first["previous"] == path[seq]
            assert first["position"] == path[seq + 1]
        for _ in range(3):  # no seq: both are new steps, one after the other, none lost
            first, second = both(None)
            earlier, later = sorted((first, second), key=lambda s: s["iteration"])
            assert later["iteration"] == earlier["iteration"] + 1
            assert later["previous"] == earlier["position"]
        detail = cb.get(f"/plan/{plan_id}").json()
        assert detail["iteration"] == 6 + 2 * 3
        assert detail["trajectory"] == path[: 6 + 2 * 3 + 1]


def test_steps_alternated_between_replicas_never_use_a_stale_copy(two: list[Replica]) -> None:
    """Each replica keeps the record it last wrote; the other's steps make it stale. A step, a
    read, a retried seq and an out-of-order seq on the stale replica all see the latest step."""
    with _client(two[0]) as ca, _client(two[1]) as cb:
        plan_id, path = _new_plan(ca)
        answers = [_step((ca, cb)[seq % 2], plan_id, seq) for seq in range(4)]  # A B A B
        for seq, answer in enumerate(answers):
            assert (answer["previous"], answer["position"]) == (path[seq], path[seq + 1])
        assert ca.get(f"/plan/{plan_id}").json()["iteration"] == 4  # read, not A's copy
        assert _step(ca, plan_id, 3) == answers[3]  # B's answer, replayed by A
        answers.append(_step(cb, plan_id, 4))
        # A's copy (refreshed above) says seq 3 was the last: Redis says 4, so 3 is refused.
        late = ca.post(f"/plan/{plan_id}/step", json={"seq": 3})
        assert late.status_code == 409, late.text
        for client in (ca, cb, ca):  # no seq: each steps on from the other's move
            answers.append(_step(client, plan_id, None))
            assert answers[-1]["iteration"] == answers[-2]["iteration"] + 1
            assert answers[-1]["previous"] == answers[-2]["position"]
        detail = cb.get(f"/plan/{plan_id}").json()
        assert detail["iteration"] == 8
        assert detail["trajectory"] == path[:9]


def test_redis_down_answers_503_and_service_resumes_when_it_returns(tmp_path: Path) -> None:
    server = RedisServer(tmp_path / "redis", persistent=True)
    server.start()
    try:
        with replicas(server.url, tmp_path, 1) as (replica,), _client(replica) as client:
            plan_id, path = _new_plan(client)
            answers = [_step(client, plan_id, seq) for seq in range(3)]

            server.stop()  # mid-episode
            down = "store unavailable; retry later"  # where and why go to the log only
            for method, url, body in [
                ("POST", f"/plan/{plan_id}/step", {"seq": 3}),
                ("GET", f"/plan/{plan_id}", None),
                ("POST", "/maps", {"grid": [[0, 0], [0, 1]]}),
            ]:
                r = client.request(method, url, json=body)
                assert r.status_code == 503, r.text
                assert r.json()["code"] == "STORE_UNAVAILABLE"
                assert r.json()["detail"] == down
                assert str(server.port) not in r.text
                assert r.headers["retry-after"] == "1"
            ready = client.get("/readyz")
            assert ready.status_code == 503
            assert ready.json()["status"] == "unavailable"
            assert ready.json()["store"]["up"] is False
            assert ready.json()["store"]["detail"] == down
            assert str(server.port) not in ready.text
            assert client.get("/healthz").status_code == 200  # alive all the same

            server.start()  # same port, same append-only file: the data is back
            for _ in range(600):
                if client.get("/readyz").status_code == 200:
                    break
                time.sleep(0.05)
            assert client.get("/readyz").json()["store"] == {
                "kind": "redis", "up": True, "detail": None
            }  # fmt: skip
            assert _step(client, plan_id, 2) == answers[-1]  # nothing lost, nothing moved
            seq = 3
            while answers[-1]["status"] != "arrived":
                answers.append(_step(client, plan_id, seq))
                assert answers[-1]["previous"] == path[seq]
                seq += 1
            detail = client.get(f"/plan/{plan_id}").json()
            assert detail["trajectory"] == path
            assert detail["iteration"] == len(path) - 1
    finally:
        server.stop()
