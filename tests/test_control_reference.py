"""A reference interpreter of the control-flow rules, and the generated trees held to it (docs/semantics.md#control-flow).

The interpreter below is a plain event simulation of the rules as docs/semantics.md states them - entries
waiting, running, retried, repeated, stopped and cut, tick by tick - written without py_trees, without the
package's nodes and without its tree. Hypothesis draws random timelines (random ``after``/``join``) with
random control keys on random entries, random ``stops`` and races, a random top-level ``stop``, and random
``record``/``final`` criteria; each is run by the generated tree against the simulated system and by the
interpreter, at tick 0.1 and at tick 0.07 (not a power-of-ten fraction: every duration falls between ticks),
and the two must agree on the run's end tick, its verdict and every entry's status, start and end.

Conditions (``when``, ``stop``) read the entries' states (``A.ended``, ``B.running``, ...): those are the
same whatever the tree's order, which is what makes one reference possible. Criteria read the signals the
entries ``set`` (every entry sets its own signal when its action starts), judged after the whole timeline
ticked.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import random

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from btgen_pytrees import load
from btgen_pytrees.run import run

TICKS = (0.1, 0.07)
TIMEOUT = 4.0
STATES = ("started", "running", "ended", "succeeded", "failed", "stopped")


def reached(elapsed: float, duration: float) -> bool:
    """The timing rule (docs/semantics.md#the-timing-rule): now >= start + d, a nanosecond per second of d."""
    return elapsed >= duration - 1e-9 * max(1.0, abs(duration))


# -- the case: what hypothesis draws ------------------------------------------------------------------------


@dataclass
class Spec:
    id: str
    fails: bool  # the action: `until false` (fails after d) or `set` (succeeds after d)
    duration: float
    after: list[str]
    join: str
    control: dict[str, Any]


@dataclass
class Case:
    entries: list[Spec]
    stop: list[dict[str, Any]]
    criteria: list[tuple[str, str, str]]  # (id, type, expect)

    def document(self, tick: float) -> dict[str, Any]:
        execute = []
        for e in self.entries:
            if e.fails:
                raw: dict[str, Any] = {"id": e.id, "kind": "constraint", "action": "until",
                                       "params": {"expect": "false", "timeout": e.duration}}  # fmt: skip
            else:
                raw = {"id": e.id, "kind": "behavior", "action": "set",
                       "params": {"signal": f"s_{e.id}", "value": 1, "duration": e.duration}}  # fmt: skip
            if e.after:
                raw["after"] = e.after
                raw["join"] = e.join
            raw.update(e.control)
            execute.append(raw)
        data: dict[str, Any] = {"name": "reference", "tick": tick, "timeout": TIMEOUT, "execute": execute,
                                "signals": {f"s_{e.id}": 0 for e in self.entries}}  # fmt: skip
        if self.stop:
            data["stop"] = self.stop
        if self.criteria:
            data["oracle"] = {"criteria": [{"id": i, "type": t, "expect": x} for i, t, x in self.criteria]}
        return data


DURATIONS = [0.0, 0.1, 0.2, 0.25, 0.3, 0.5, 0.7, 1.0]


def draw_case(seed: int) -> Case:
    """A random case from *seed* (hypothesis draws the seeds: one number per case keeps its own cost small, so the
    thousand cases cost what their runs cost)."""
    rnd = random.Random(seed)
    n = rnd.randint(2, 7)
    ids = [f"E{i}" for i in range(n)]
    specs: list[Spec] = []
    for i, id_ in enumerate(ids):
        after = rnd.sample(ids[:i], rnd.randint(0, min(3, i)))
        control: dict[str, Any] = {}
        if rnd.randint(0, 2):  # two in three entries have control keys
            others = [x for x in ids if x != id_]
            if rnd.random() < 0.5:
                other, state = rnd.choice(others), rnd.choice(STATES)
                control["when"] = rnd.choice([f"{other}.{state}", f"!{other}.{state}",
                                              f"{other}.{state} || {rnd.choice(others)}.running"])  # fmt: skip
                edge = rnd.choice(["none", "none", "rising", "falling", "any"])
                if edge != "none":
                    control["edge"] = edge
            if rnd.random() < 0.5:
                control["delay"] = rnd.choice([0, 0.1, 0.15, 0.3, 1])
            if rnd.random() < 0.5:
                control["timeout"] = rnd.choice([0.1, 0.25, 0.5, 1])
            if rnd.random() < 0.5:
                control["attempts"] = rnd.randint(1, 3)
            if rnd.random() < 0.5:
                control["repeat"] = rnd.randint(1, 3)
            if rnd.random() < 0.25:
                control["stops"] = rnd.sample(others, rnd.randint(1, min(2, len(others))))
        specs.append(Spec(id_, rnd.random() < 0.2, rnd.choice(DURATIONS), after, rnd.choice(["any", "all"]), control))
    if rnd.random() < 1 / 3:  # a race of two or three entries, none repeating
        members = rnd.sample(ids, rnd.randint(2, min(3, n)))
        for spec in specs:
            if spec.id in members:
                spec.control["race"] = "r"
                spec.control.pop("repeat", None)
    stop = []
    if rnd.random() < 1 / 3:
        item: dict[str, Any] = {"when": f"{rnd.choice(ids)}.{rnd.choice(['ended', 'running', 'started'])}"}
        if rnd.random() < 0.5:
            item["delay"] = rnd.choice([0, 0.2, 0.5])
        if rnd.random() < 0.5:
            item["edge"] = rnd.choice(["rising", "any"])
        stop.append(item)
    criteria = []
    if rnd.random() < 0.5:
        criteria.append(("F", "final", f"s_{rnd.choice(ids)} == 1 || s_{rnd.choice(ids)} == 0"))
    if rnd.random() < 0.25:
        criteria.append(("R", "record", f"s_{rnd.choice(ids)} + s_{rnd.choice(ids)} < 2"))
    return Case(specs, stop, criteria)


# -- the interpreter ----------------------------------------------------------------------------------------


@dataclass
class Gate:
    when: str | None
    edge: str
    delay: float
    last: bool | None = None
    fired: float | None = None

    def due(self, states: dict[str, bool], now: float) -> bool:
        if self.fired is None:
            value = holds(self.when, states)
            last, self.last = self.last, value
            if self.edge == "none":
                fire = value
            elif last is None:
                fire = False
            elif self.edge == "rising":
                fire = value and not last
            elif self.edge == "falling":
                fire = last and not value
            else:
                fire = value != last
            if not fire:
                return False
            self.fired = now
        return not self.delay or reached(now - self.fired, self.delay)


def holds(when: str | None, states: dict[str, bool]) -> bool:
    """A condition of the three forms the strategy writes."""
    if when is None:
        return True
    if " || " in when:
        return any(holds(part, states) for part in when.split(" || "))
    if when.startswith("!"):
        return not states[when[1:]]
    return states[when]


@dataclass
class Item:
    spec: Spec
    phase: str = "pending"  # pending, waiting, running, success, failure, stopped, cut
    since: int = -1  # the tick it became active
    start: float | None = None
    end: float | None = None
    action_start: float = 0.0  # the current attempt's start
    attempt: int = 1
    repetition: int = 1
    gate: Gate | None = None
    requests: list[int] = field(default_factory=list)  # ticks of the stop requests written for it
    state: dict[str, bool] = field(default_factory=lambda: dict.fromkeys(STATES, False))

    @property
    def control(self) -> dict[str, Any]:
        return self.spec.control

    def new_gate(self) -> Gate | None:
        c = self.control
        if "when" not in c and not c.get("delay"):
            return None
        return Gate(c.get("when"), c.get("edge", "none"), float(c.get("delay", 0)))


def interpret(case: Case, tick: float) -> tuple[str, int, dict[str, tuple[str, float | None, float | None]]]:
    """(verdict, ticks, {id: (status, start, end)}) of *case* at *tick*, by the rules alone."""
    items = {s.id: Item(s) for s in case.entries}
    order = [items[s.id] for s in case.entries]
    signals = {f"s_{s.id}": 0 for s in case.entries}
    visible = {f"{i}.{s}": False for i in items for s in STATES}  # the states as the tick sees them
    stop_gates = [Gate(s["when"], s.get("edge", "none"), float(s.get("delay", 0))) for s in case.stop]
    rivals = {s.id: [x.id for x in case.entries if x.id != s.id and "race" in x.control and "race" in s.control]
              for s in case.entries}  # fmt: skip
    last_tick = int(TIMEOUT / tick + 1e-9)
    finals = [c for c in case.criteria if c[1] == "final"]
    records = [c for c in case.criteria if c[1] == "record"]
    verdict = ""
    k = 0
    for k in range(last_tick + 1):
        now = round(k * tick, 9)
        # the stop, before any entry
        fired = False
        for gate in stop_gates:
            if gate.due(visible, now) and not fired:
                fired = True
        failed = False
        if fired:
            for it in order:
                if it.phase == "running":
                    it.phase = "halted"  # reported `stopped` with no end: the run ended around it
                elif it.phase == "waiting":
                    it.phase = "halted-waiting"
            execute_done = True
        else:
            # stop requests of earlier ticks, for the entries active then
            for it in order:
                if it.phase in ("waiting", "running") and any(it.since <= r < k for r in it.requests):
                    finish(it, "stopped", now)
            changed = True
            ticked: set[str] = set()
            while changed:  # what starts on this tick because something ended on it
                changed = False
                for it in order:
                    if it.phase == "pending":
                        preds = [items[p] for p in it.spec.after]
                        if preds:
                            ok = [p.phase == "success" for p in preds]
                            dead = [p.phase in ("stopped", "cut") for p in preds]
                            if it.spec.join == "any" and any(ok) or it.spec.join == "all" and all(ok):
                                activate(it, k)
                            elif it.spec.join == "any" and all(dead) or it.spec.join == "all" and any(dead):
                                it.phase = "cut"
                                changed = True
                                continue
                            else:
                                continue
                        else:
                            activate(it, k)
                        changed = True
                    if it.phase in ("waiting", "running") and it.spec.id not in ticked:
                        ticked.add(it.spec.id)
                        changed = True
                        result = step(it, now, k, visible, signals, items, rivals)
                        failed = failed or result == "failure"
            execute_done = all(it.phase in ("success", "stopped", "cut") for it in order)
        # the oracle, after the timeline
        if records and any(eval_expect(x, signals) is False for _, _, x in records):
            verdict = "fail"
        elif failed:
            verdict = "fail"
        elif execute_done and finals:
            verdict = "pass" if all(eval_expect(x, signals) for _, _, x in finals) else "fail"
        elif execute_done and not finals:
            verdict = "pass"
        if verdict:
            break
        for it in order:  # the states the next tick sees
            for state in STATES:
                visible[f"{it.spec.id}.{state}"] = it.state[state]
    else:
        verdict = "timeout"
    out = {}
    for it in order:
        phase = it.phase
        if phase in ("success", "failure", "stopped"):
            out[it.spec.id] = (phase, it.start, it.end)
        elif phase == "running" or phase == "halted":
            out[it.spec.id] = ("running" if verdict == "timeout" else "stopped", it.start, None)
        elif phase == "waiting" and it.start is not None:  # between repetitions
            out[it.spec.id] = ("running" if verdict == "timeout" else "stopped", it.start, None)
        elif phase == "halted-waiting" and it.start is not None:
            out[it.spec.id] = ("stopped", it.start, None)
        else:
            out[it.spec.id] = ("not-started", None, None)
    return verdict, k + 1, out


def eval_expect(text: str, signals: dict[str, int]) -> bool:
    if " || " in text:
        left, right = text.split(" || ")
        return eval_expect(left, signals) or eval_expect(right, signals)
    if "+" in text:
        a, rest = text.split(" + ")
        b, _ = rest.split(" < ")
        return signals[a] + signals[b] < 2
    name, value = text.split(" == ")
    return signals[name] == int(value)


def activate(it: Item, k: int) -> None:
    it.phase, it.since = "waiting", k
    it.gate = it.new_gate()
    it.repetition, it.attempt = 1, 1


def begin(it: Item, now: float, k: int, items: dict[str, Item], signals: dict[str, int]) -> None:
    """The action starts (the first attempt of a repetition)."""
    it.phase = "running"
    if it.start is None:
        it.start = now
    it.state["started"] = it.state["running"] = True
    start_attempt(it, now, signals)
    for target in it.control.get("stops", ()):
        items[target].requests.append(k)


def start_attempt(it: Item, now: float, signals: dict[str, int]) -> None:
    it.action_start = now
    if not it.spec.fails:
        signals[f"s_{it.spec.id}"] = 1


def finish(it: Item, how: str, now: float) -> None:
    it.phase, it.end = how, now
    it.state["running"] = False
    it.state["ended"] = True
    it.state[{"success": "succeeded", "failure": "failed", "stopped": "stopped"}[how]] = True


def step(it: Item, now: float, k: int, visible: dict[str, bool], signals: dict[str, int], items: dict[str, Item],
         rivals: dict[str, list[str]]) -> str:  # fmt: skip
    """Tick entry *it* once (with the same-tick restarts of attempts and repetitions)."""
    c = it.control
    while True:
        if it.phase == "waiting":
            if it.gate is not None and not it.gate.due(visible, now):
                return "running"
            begin(it, now, k, items, signals)
        # the action's tick: d seconds after the attempt's start it ends
        done = reached(now - it.action_start, it.spec.duration)
        if done:
            outcome = "failure" if it.spec.fails else "success"
        elif "timeout" in c and reached(now - it.action_start, c["timeout"]):
            outcome = "failure"
        else:
            return "running"
        if outcome == "failure":
            if it.attempt < c.get("attempts", 1):
                it.attempt += 1
                start_attempt(it, now, signals)
                continue
            finish(it, "failure", now)
            return "failure"
        if it.repetition < c.get("repeat", 1):
            it.repetition += 1
            it.attempt = 1
            it.phase = "waiting"
            it.state["running"] = False
            it.gate = it.new_gate()
            continue
        finish(it, "success", now)
        for rival in rivals[it.spec.id]:
            items[rival].requests.append(k)
        return "success"


# -- the property ----------------------------------------------------------------------------------------------


def observed(case: Case, tick: float) -> tuple[str, int, dict[str, tuple[str, float | None, float | None]]]:
    report = run(load(case.document(tick)), record=False)
    return report.verdict, report.ticks, {e.id: (e.status, e.start, e.end) for e in report.execute}


@settings(max_examples=1000, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(st.integers(0, 2**32 - 1))
def test_the_tree_runs_as_the_reference_interpreter(seed: int) -> None:
    case = draw_case(seed)
    for tick in TICKS:
        assert observed(case, tick) == interpret(case, tick), (tick, case.document(tick))
