"""Creating a Mitsuba object (a texture, an emitter) inside a plugin's
constructor: through Mitsuba's plugin manager, never its scene parser.

``mi.load_dict`` (and ``load_string``, ``load_file``) replaces Mitsuba's
process-wide file resolver with a copy while it runs and puts the old one
back when done, freeing the copy. ``mi.load_file`` loads a scene in parallel
by default: while one plugin's constructor runs, others run on other
threads, and some of them read the resolver (``sunsky`` for its data files,
the plugin manager to find a plugin's library the first time). A
``load_dict`` inside a constructor can therefore free the resolver another
thread is reading. Mitsuba 3.9.1 then fails with ``basic_string::_M_create``,
``std::bad_alloc``, ``The file "data/sunsky/sunsky_datasets.bin" does not
exist`` or a segmentation fault, from a ``sunsky`` or a ``checkerboard``
loaded beside a ``pbrdf`` that names its ``material`` (seen in the test suite
once in a few runs; a thread calling ``load_dict`` in a loop beside one
loading a ``sunsky`` scene breaks it within seconds,
``tests/test_plugin_objects.py``). The plugin manager touches no resolver.
"""

from __future__ import annotations

__all__ = ["create"]


def create(plugin_type: str, **params):
    """A new instance of Mitsuba plugin *plugin_type* (``"irregular"``,
    ``"sunsky"``, ...) of the active variant, with *params* as its properties.
    Values are set as given, so give them the types the plugin reads:
    ``float``, ``int``, ``bool``, ``str``, Mitsuba objects (a texture, a
    bitmap), ``mi.ScalarColor3f`` for a colour, ``mi.ScalarVector3f`` for a
    vector, ``mi.ScalarTransform4f`` for a transform. Nested plugins are
    created first and passed as objects. Raises Mitsuba's ``RuntimeError``
    when the plugin refuses its parameters."""
    import mitsuba as mi

    props = mi.Properties(plugin_type)
    for key, value in params.items():
        props[key] = value
    return mi.PluginManager.instance().create_object(props)
