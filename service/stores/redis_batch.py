"""The Redis store's batching of step scripts (docs/redis-store.md#batching-writes): the calls
made in one turn of the event loop go out together, one round trip."""

from __future__ import annotations

import asyncio
from typing import Any

from redis import exceptions as rx
from redis.asyncio import Redis
from redis.commands.core import AsyncScript

__all__ = ["Collector"]

_Call = tuple[list[str], list[Any], "asyncio.Future[Any]"]


class Collector:
    """The step script's calls made in one turn of the event loop while another is in flight,
    sent together in one ``pipeline(transaction=False)`` by a task of their own (a caller that
    gives up cancels nobody else's call); a lone call is sent as the script itself. A call made
    when none is in flight or waiting goes out at once from its caller: no task, no hop through
    the loop (one step at a time, as at one connection, never waits a turn for company)."""

    def __init__(self, redis: Redis, script: AsyncScript) -> None:
        self._redis, self._script = redis, script
        self._calls: list[_Call] = []
        self._sending: set[asyncio.Task[None]] = set()
        self._callers: set[asyncio.Task[Any]] = set()  # sending their own call, in flight
        self._closing = False
        self.pipelines = 0
        """Round trips made (for tests: calls that shared one)."""

    async def __call__(self, *, keys: list[str], args: list[Any]) -> Any:
        if not (self._callers or self._calls or self._sending):
            return await self._alone(keys, args)
        loop = asyncio.get_running_loop()
        answer: asyncio.Future[Any] = loop.create_future()
        self._calls.append((keys, args, answer))
        if len(self._calls) == 1:  # the first of this turn: the others join it
            task = loop.create_task(self._send())
            self._sending.add(task)
            task.add_done_callback(self._sending.discard)
        return await answer

    async def _alone(self, keys: list[str], args: list[Any]) -> Any:
        """A call sent by its caller; failed, as a collected call is, when the store closes
        meanwhile (redis-py may finish a call it was cancelled in: the cancel is then noted)."""
        task = asyncio.current_task()
        assert task is not None
        self.pipelines += 1
        self._callers.add(task)
        try:
            answer = await self._script(keys=keys, args=args)
        except asyncio.CancelledError:
            if self._closing and task.uncancel() == 0:  # the store's cancel, not another's
                raise rx.ConnectionError("the store is closing") from None
            raise
        finally:
            self._callers.discard(task)
        if self._closing and task.cancelling() and task.uncancel() == 0:
            raise rx.ConnectionError("the store is closing")
        return answer

    async def _send(self) -> None:
        calls = [call for call in self._calls if not call[2].done()]
        self._calls = []
        if not calls:
            return
        self.pipelines += 1
        answers: list[Any]
        try:
            if len(calls) == 1:
                answers = [await self._script(keys=calls[0][0], args=calls[0][1])]
            else:
                answers = await self._pipeline(calls)
        except Exception as exc:  # Redis out of reach, after redis-py's one retry
            answers = [exc] * len(calls)
        except BaseException:  # the store closing
            answers = [rx.ConnectionError("the store is closing")] * len(calls)
            raise
        finally:
            for (*_, answer), value in zip(calls, answers, strict=True):
                if answer.done():  # its caller gave up
                    continue
                if isinstance(value, BaseException):
                    answer.set_exception(value)
                else:
                    answer.set_result(value)

    async def _pipeline(self, calls: list[_Call]) -> list[Any]:
        async with self._redis.pipeline(transaction=False) as pipe:
            for keys, args, _ in calls:
                pipe.evalsha(self._script.sha, len(keys), *keys, *args)
            answers: list[Any] = await pipe.execute(raise_on_error=False)
        for i, answer in enumerate(answers):
            if isinstance(answer, rx.NoScriptError):  # Redis restarted: the script loads itself
                try:
                    answers[i] = await self._script(keys=calls[i][0], args=calls[i][1])
                except rx.RedisError as exc:
                    answers[i] = exc
        return answers

    async def close(self) -> None:
        self._closing = True
        for task in [*self._sending, *self._callers]:
            task.cancel()
        await asyncio.gather(*self._sending, return_exceptions=True)
        for *_, answer in self._calls:  # their task was cancelled before it began
            if not answer.done():
                answer.set_exception(rx.ConnectionError("the store is closing"))
        self._calls = []
