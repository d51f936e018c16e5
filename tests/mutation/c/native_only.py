"""pytest plugin of the C mutation runner (tests/mutation/c/run.py, ``-p``): deselects the
tests parametrised on the pythonfmu flavour (a parameter id ``pythonfmu``), which judge the
Python adapters, not the C. Not a ``-k`` expression: ``-k "not pythonfmu"`` would also drop
the tests whose own name says pythonfmu, such as test_flavours.py's comparison of the native
flavour with the pythonfmu one, bit for bit, on every scenario."""


def pytest_collection_modifyitems(config, items):
    keep, drop = [], []
    for item in items:
        callspec = getattr(item, "callspec", None)
        (drop if callspec and "pythonfmu" in callspec.id.split("-") else keep).append(item)
    if drop:
        config.hook.pytest_deselected(items=drop)
        items[:] = keep
