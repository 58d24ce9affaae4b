"""Reading a wrapper's parameters (nested objects, booleans), with one-line
errors that name the plugin. Plain functions: ``mi.*`` is looked up when
called, so this module serves every variant without a reload."""

import mitsuba as mi


def nested_objects(props, kinds):
    """The objects of ``props`` that are instances of ``kinds``, by key."""
    return {key: props[key] for key in props.keys()
            if props.type(key) == mi.Properties.Type.Object and isinstance(props[key], kinds)}


def single_nested_bsdf(props, name):
    """The one nested BSDF of a wrapper ``name``; a one-line error otherwise."""
    bsdfs = nested_objects(props, mi.BSDF)
    if len(bsdfs) != 1:
        raise ValueError(f"{name}: exactly one nested BSDF must be given, found {len(bsdfs)}")
    return next(iter(bsdfs.values()))


def flag(props, name, key, default):
    """A boolean parameter."""
    if key not in props:
        return default
    if props.type(key) != mi.Properties.Type.Bool:
        raise TypeError(f"{name}: parameter '{key}' must be a boolean")
    return bool(props[key])
