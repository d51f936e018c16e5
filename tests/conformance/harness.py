"""An FMU instance driven through the FMI 2.0 API only (fmpy's FMU2Slave, or FMU2Model for
Model Exchange: ``interface="me"``): every call returns its status, and the instance's log
is collected as (status, message)."""
from __future__ import annotations

import ctypes
import math
import shutil

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (FMU2Model, FMU2Slave, calloc, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, free)
from fmpy.logging import addLoggerProxy

OK = 0


class Fmu:
    def __init__(self, path, name, interface="cs", **parameters):
        self.md = read_model_description(str(path))
        self.interface = interface
        self.unzipdir = extract(str(path))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.log: list[tuple[int, str]] = []
        self.callbacks = fmi2CallbackFunctions()
        self._logger = fmi2CallbackLoggerTYPE(self._on_message)
        self.callbacks.logger = self._logger
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(ctypes.byref(self.callbacks))
        kind = FMU2Model if interface == "me" else FMU2Slave
        self.fmu = kind(guid=self.md.guid, unzipDirectory=self.unzipdir,
                        modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(callbacks=self.callbacks, loggingOn=True)
        self.time = 0.0
        for k, v in parameters.items():
            assert self.set(**{k: v}) == OK, (k, v, self.log)

    def _on_message(self, env, instance, status, category, message):
        self.log.append((status, message.decode("utf-8", "replace") if message else ""))

    dead = False  # after fmi2Fatal nothing may be called on the instance (FMI 2.0, 2.1.3)

    def _status(self, call, *args):
        assert not self.dead, "an FMI call after fmi2Fatal"
        try:
            return OK, call(*args)
        except FMICallException as e:
            self.dead = e.status >= 4
            return e.status, None

    def messages(self, since=0):
        return " | ".join(m for _, m in self.log[since:])

    # -- variables ------------------------------------------------------------
    # FMI type -> the suffix of fmpy's set/get method and the Python type it takes
    TYPES = {"Real": ("Real", float), "Integer": ("Integer", int), "Boolean": ("Boolean", bool)}

    def set(self, **values) -> int:
        worst = OK
        for name, value in values.items():
            v = self.vars[name]
            suffix, kind = self.TYPES[v.type]
            st, _ = self._status(getattr(self.fmu, "set" + suffix), [v.valueReference], [kind(value)])
            worst = max(worst, st)
        return worst

    def get(self, name):
        v = self.vars[name]
        suffix, kind = self.TYPES[v.type]
        return kind(getattr(self.fmu, "get" + suffix)([v.valueReference])[0])

    def outputs(self):
        return {n: self.get(n) for n, v in self.vars.items() if v.causality == "output"}

    # -- life cycle -----------------------------------------------------------
    def init(self, start=0.0) -> int:
        self.time = start
        st, _ = self._status(self.fmu.setupExperiment, None, start)
        if st:
            return st
        st, _ = self._status(self.fmu.enterInitializationMode)
        if st:
            return st
        st, _ = self._status(self.fmu.exitInitializationMode)
        return st

    def call(self, name, *args):
        """(status, result) of the FMI call `name` (fmpy's method name) on the instance."""
        return self._status(getattr(self.fmu, name), *args)

    def step(self, h, t=None) -> int:
        t = self.time if t is None else t
        st, _ = self._status(self.fmu.doStep, t, h)
        if st == OK:
            self.time = t + h
        return st

    def terminate(self) -> int:
        return self._status(self.fmu.terminate)[0]

    def reset(self) -> int:
        self.time = 0.0
        return self._status(self.fmu.reset)[0]

    def get_state(self):
        return self.fmu.getFMUState()

    def set_state(self, state) -> int:
        return self._status(self.fmu.setFMUState, state)[0]

    def serialize(self, state) -> bytes:
        return bytes(self.fmu.serializeFMUState(state))

    def deserialize(self, blob: bytes):
        return self._status(self.fmu.deserializeFMUState, bytes(blob))

    def free(self):
        try:
            if not self.dead:  # after fmi2Fatal the instance is left as it is (leaked)
                self.fmu.freeInstance()
        finally:
            shutil.rmtree(self.unzipdir, ignore_errors=True)


def finite(values) -> bool:
    return all(math.isfinite(v) for v in values if isinstance(v, float))


class Fmu3(Fmu):
    """The same driver on an FMI 3.0 archive (fmpy's FMU3Model for ``interface="me"``, else
    FMU3Slave): `call` takes FMI 2.0's function names and calls FMI 3.0's counterpart, so that
    one test runs on both versions; messages name FMI 3.0's functions and states."""

    NAMES = {"getDerivatives": "getContinuousStateDerivatives", "newDiscreteStates": "updateDiscreteStates",
             "getReal": "getFloat64"}
    TYPES = {"Float64": ("Float64", float), "Int32": ("Int32", int), "Boolean": ("Boolean", bool)}

    def __init__(self, path, name, interface="cs", **parameters):
        from fmpy.fmi3 import FMU3Model, FMU3Slave
        self.md = read_model_description(str(path))
        self.interface = interface
        self.unzipdir = extract(str(path))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.log: list[tuple[int, str]] = []
        kind = FMU3Model if interface == "me" else FMU3Slave
        self.fmu = kind(guid=self.md.guid, unzipDirectory=self.unzipdir,
                        modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(loggingOn=True, logMessage=self._on_message)
        self.time = 0.0
        for k, v in parameters.items():
            assert self.set(**{k: v}) == OK, (k, v, self.log)

    def _on_message(self, env, status, category, message):
        self.log.append((status, message.decode("utf-8", "replace") if message else ""))

    def call(self, name, *args):
        return self._status(getattr(self.fmu, self.NAMES.get(name, name)), *args)

    def init(self, start=0.0) -> int:
        self.time = start
        st, _ = self._status(self.fmu.enterInitializationMode, None, start)
        if st:
            return st
        return self._status(self.fmu.exitInitializationMode)[0]


def driver(version: int) -> type:
    """the driver of FMI version `version`'s archives: Fmu (2) or Fmu3 (3)"""
    return {2: Fmu, 3: Fmu3}[version]


# FMI 2.0's function and state names as FMI 3.0 writes them, where they differ
FMI3_FUNCTIONS = {"GetDerivatives": "GetContinuousStateDerivatives", "NewDiscreteStates": "UpdateDiscreteStates",
                  "GetFMUstate": "GetFMUState", "SetFMUstate": "SetFMUState", "FreeFMUstate": "FreeFMUState",
                  "SerializeFMUstate": "SerializeFMUState", "DeSerializeFMUstate": "DeserializeFMUState",
                  "SetupExperiment": "EnterInitializationMode"}
STATES = {2: {"instantiated": "instantiated", "eventMode": "eventMode", "terminated": "terminated"},
          3: {"instantiated": "Instantiated", "eventMode": "Event Mode", "terminated": "Terminated"}}


def fmi_name(version: int, name: str) -> str:
    """an FMI function's name (FMI 2.0's, capitalised and without prefix: "GetDerivatives") or
    a state's ("instantiated"), as the messages of FMI version `version` write it"""
    if name[0].isupper():
        return f"fmi2{name}" if version == 2 else f"fmi3{FMI3_FUNCTIONS.get(name, name)}"
    return STATES[version][name]
