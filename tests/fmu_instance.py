"""An FMU instance on fmpy's FMU2Slave with its log collected: shared by the FMU tests."""
from __future__ import annotations

import ctypes
import shutil

from fmpy import extract, read_model_description
from fmpy.fmi2 import (FMU2Slave, calloc, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, free)
from fmpy.logging import addLoggerProxy


class Instance:
    """One instantiated FMU; ``messages`` collects (status, text) of its log.

    fmpy's native logger proxy keeps one logger for the whole process (the last one
    registered), so a message is filed by the instance name the FMU reports: give the
    instances that live at the same time different names."""

    _by_name: dict = {}

    def __init__(self, path, name, environment=None, **parameters):
        """environment: the componentEnvironment pointer handed to fmi2Instantiate (an int);
        ``environments`` collects what the FMU hands back with each message."""
        self.md = read_model_description(str(path))
        self.unzipdir = extract(str(path))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.messages: list[tuple[int, str]] = []
        self.environments: list[int | None] = []
        self.name = name
        Instance._by_name[name] = self
        self.callbacks = fmi2CallbackFunctions()
        self._logger = fmi2CallbackLoggerTYPE(self._on_message)  # keep a reference
        self.callbacks.logger = self._logger
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.callbacks.componentEnvironment = environment
        addLoggerProxy(ctypes.byref(self.callbacks))
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzipdir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(callbacks=self.callbacks, loggingOn=True)
        self.set(**parameters)

    @property
    def log(self) -> list[tuple[int, str]]:
        """``messages`` under the name harness.Fmu and the in-process instances give it."""
        return self.messages

    def _on_message(self, env, instance, status, category, message):
        name = instance.decode("utf-8", "replace") if instance else self.name
        target = Instance._by_name.get(name, self)
        target.messages.append((status, message.decode("utf-8", "replace") if message else ""))
        target.environments.append(env)

    def set(self, **values):
        for name, value in values.items():
            v = self.vars[name]
            if v.type == "Real":
                self.fmu.setReal([v.valueReference], [float(value)])
            elif v.type == "Integer":
                self.fmu.setInteger([v.valueReference], [int(value)])
            else:
                self.fmu.setBoolean([v.valueReference], [bool(value)])

    def get(self, name):
        v = self.vars[name]
        if v.type == "Real":
            return self.fmu.getReal([v.valueReference])[0]
        if v.type == "Integer":
            return self.fmu.getInteger([v.valueReference])[0]
        return bool(self.fmu.getBoolean([v.valueReference])[0])

    def reals(self, names):
        return list(self.fmu.getReal([self.vars[n].valueReference for n in names]))

    def initialize(self, start=0.0):
        self.fmu.setupExperiment(startTime=start)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def close(self):
        try:
            self.fmu.terminate()
        finally:
            self.fmu.freeInstance()
            shutil.rmtree(self.unzipdir, ignore_errors=True)
            if Instance._by_name.get(self.name) is self:
                del Instance._by_name[self.name]


class Opened:
    """Instances opened by a test, all closed at its end (used by the FMU fixtures)."""

    def __init__(self):
        self.instances: list[Instance] = []

    def open(self, path, name, **parameters) -> Instance:
        inst = Instance(path, name, **parameters)
        self.instances.append(inst)
        return inst

    def close_all(self):
        for inst in self.instances:
            try:
                inst.close()
            except Exception:
                pass
