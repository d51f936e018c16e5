"""The pythonfmu flavour's slaves driven in this process, with the API of
tests/conformance/harness.Fmu, so that the conformance suite runs on them without building
an FMU (and, under mutmut, on the mutated copies of ballmill/fmi/slave.py, fmu_src/ and
drive_models/: a built FMU would bundle the unmutated tree, and its host would not report
to mutmut).

What pythonfmu's C wrapper (0.7.0) does around the Python object is done here the same way
(docs/OTHER_TOOLS.md, tests/conformance/conftest.py): a Python exception from a call is
fmi2Fatal with the exception's text in the log; fmi2DoStep returning False is fmi2Discard;
the log queue is flushed to the logger after every call, each message as a printf format
(a '%' must come as '%%'); an FMU state is the dict of `_get_fmu_state`, serialised with
`_fmu_state_to_bytes`. fmi2Reset makes a new instance (start values, instantiated phase).
Unlike a built FMU, the Python object stays usable after fmi2Fatal, so the tests check that
a refused call kept its state."""
from __future__ import annotations

import importlib
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4
SCRIPTS = {"BallInShell": "fmu_src.ballinshell_fmu", "MotorStartup": "drive_models.motorstartup_fmu",
           "InductionMotor": "drive_models.inductionmotor_fmu", "Fig1Drive": "drive_models.fig1drive_fmu",
           "Structure": "drive_models.structure_fmu"}


def slave_class(model: str):
    """The Fmi2Slave subclass of a model, imported from its FMU script in this tree."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    return getattr(importlib.import_module(SCRIPTS[model]), model)


def printf(fmt: str) -> str:
    """What the FMI logger prints for a message handed over as a format without arguments:
    '%%' is '%'; a lone '%' would read an argument that is not there (refused here)."""
    if re.search(r"%(?!%)", fmt.replace("%%", "")):
        raise AssertionError(f"a '%' not escaped for printf in {fmt!r}")
    return fmt.replace("%%", "%")


class Var:
    def __init__(self, sv):
        self.name = sv.name
        self.valueReference = sv.value_reference
        self.type = type(sv).__name__  # Real, Integer, Boolean
        self.causality = sv.causality.name


class InProcessFmu:
    dead = False

    def __init__(self, model_name, name, /, **parameters):
        self.model_name = model_name
        self.name = name
        self.log: list[tuple[int, str]] = []
        self._new()
        self.time = 0.0
        for k, v in parameters.items():
            assert self.set(**{k: v}) == OK, (k, v, self.log)

    def _new(self):
        self.slave = slave_class(self.model_name)(instance_name=self.name)
        self.vars = {sv.name: Var(sv) for sv in self.slave.vars.values()}

    def _flush(self):
        for m in self.slave.log_queue:
            self.log.append((int(m.status), printf(m.msg)))
        self.slave.log_queue.clear()

    def _status(self, call, *args):
        try:
            result = call(*args)
        except Exception as e:  # pythonfmu: any exception is fmi2Fatal, its text logged
            self._flush()
            self.log.append((FATAL, str(e)))
            return FATAL, None
        self._flush()
        return OK, result

    def messages(self, since=0):
        return " | ".join(m for _, m in self.log[since:])

    # -- variables ------------------------------------------------------------
    def set(self, **values) -> int:
        worst = OK
        for name, value in values.items():
            v = self.vars[name]
            conv, call = {"Real": (float, self.slave.set_real), "Integer": (int, self.slave.set_integer),
                          "Boolean": (bool, self.slave.set_boolean)}[v.type]
            st, _ = self._status(call, [v.valueReference], [conv(value)])
            worst = max(worst, st)
        return worst

    def get(self, name):
        v = self.vars[name]
        call = {"Real": self.slave.get_real, "Integer": self.slave.get_integer,
                "Boolean": self.slave.get_boolean}[v.type]
        st, values = self._status(call, [v.valueReference])
        assert st == OK, self.messages()
        return values[0]

    def outputs(self):
        return {n: self.get(n) for n, v in self.vars.items() if v.causality == "output"}

    # -- life cycle -----------------------------------------------------------
    def init(self, start=0.0) -> int:
        self.time = start
        for call, args in ((self.slave.setup_experiment, (start, None, None)),
                           (self.slave.enter_initialization_mode, ()),
                           (self.slave.exit_initialization_mode, ())):
            st, _ = self._status(call, *args)
            if st:
                return st
        return OK

    def step(self, h, t=None) -> int:
        t = self.time if t is None else t
        st, done = self._status(self.slave.do_step, t, h)
        if st:
            return st
        if not done:
            return DISCARD
        self.time = t + h
        return OK

    def terminate(self) -> int:
        return self._status(self.slave.terminate)[0]

    def reset(self) -> int:
        self.time = 0.0
        self._new()
        return OK

    def get_state(self):
        st, state = self._status(self.slave._get_fmu_state)
        assert st == OK, self.messages()
        return state

    def set_state(self, state) -> int:
        return self._status(self.slave._set_fmu_state, state)[0]

    def serialize(self, state) -> bytes:
        return bytes(self.slave._fmu_state_to_bytes(state))

    def deserialize(self, blob: bytes):
        return self._status(self.slave._fmu_state_from_bytes, bytes(blob))

    def free(self):
        pass


def open_fmu(model: str, /, **parameters) -> InProcessFmu:
    """An instance of `model` (instance name: the model's name in lower case) with `parameters` set."""
    return InProcessFmu(model, model.lower(), **parameters)


def write_model_descriptions(directory: Path) -> dict:
    """model name -> modelDescription.xml written by its slave's `to_xml` (what the
    pythonfmu build puts in the FMU), for tests that read a model description."""
    from xml.etree.ElementTree import ElementTree

    paths = {}
    for model in SCRIPTS:
        slave = slave_class(model)(instance_name="md")
        path = Path(directory) / model / "modelDescription.xml"
        path.parent.mkdir(parents=True, exist_ok=True)
        ElementTree(slave.to_xml()).write(path, encoding="utf-8", xml_declaration=True)
        paths[model] = path
    return paths


def _step_failed(status, text):
    """What fmpy raises for a doStep that is not fmi2OK (FMICallException, with its status),
    also a RuntimeError as before, with the log's text."""
    from fmpy.fmi1 import FMICallException

    class StepFailed(FMICallException, RuntimeError):
        def __str__(self):
            return f"doStep returned status {self.status}: {text}"
    return StepFailed("fmi2DoStep", status)


class _Calls:
    """fmpy FMU2Slave's doStep on an InProcessFmu: a status other than fmi2OK raises."""

    def __init__(self, owner):
        self.owner = owner

    def doStep(self, currentCommunicationPoint, communicationStepSize, noSetFMUStatePriorToCurrentPoint=True):
        st = self.owner.step(communicationStepSize, t=currentCommunicationPoint)
        if st != OK:
            raise _step_failed(st, self.owner.messages())


class Instance(InProcessFmu):
    """tests/fmu_instance.Instance's API (md, set, get, initialize, fmu.doStep) over a slave
    in this process; `path` is the model's name."""

    _md_cache: dict = {}

    def __init__(self, path, name, **parameters):
        super().__init__(str(path), name, **parameters)
        self.fmu = _Calls(self)
        if self.model_name not in Instance._md_cache:
            import tempfile

            from fmpy import read_model_description
            with tempfile.TemporaryDirectory() as d:
                paths = write_model_descriptions(Path(d))
                for model, p in paths.items():
                    Instance._md_cache[model] = read_model_description(str(p))
        self.md = Instance._md_cache[self.model_name]

    def set(self, **values):
        st = super().set(**values)
        if st != OK:
            raise RuntimeError(f"set{values} returned status {st}: {self.messages()}")
        return st

    def reals(self, names):
        return [float(self.get(n)) for n in names]

    def initialize(self, start=0.0):
        st = self.init(start)
        if st != OK:
            raise RuntimeError(f"initialisation returned status {st}: {self.messages()}")

    def close(self):
        pass


class Opened:
    def open(self, path, name, **parameters):
        return Instance(path, name, **parameters)

    def close_all(self):
        pass
