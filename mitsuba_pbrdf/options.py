"""The model's named options and default parameter values, in one place.

Pure Python, no imports: the plugin, the reference evaluator, the command line
and the fitting code all read their choice lists and defaults from here, so
that a new option is added once. (The plugin and the reference still compute
the model independently; only these names are shared.)
"""

#: Shadowing-masking functions G: the paper's V-groove (Torrance-Sparrow /
#: Blinn) and Smith's (Mitsuba's ``roughconductor``).
SHADOWING = ("vgroove", "smith")

#: The reference evaluator also offers ``"none"`` (G = 1: the original
#: Priest-Germer model, unbounded at grazing; for validation plots only).
REFERENCE_SHADOWING = SHADOWING + ("none",)

#: Normal distributions of the directional diffuse lobe.
DD_DISTRIBUTIONS = ("beckmann", "ggx")

#: Sampling strategies of the plugin: the lobe mixture, or cosine-weighted
#: hemisphere sampling (the benchmarks' baseline).
SAMPLING = ("mixture", "cosine")

#: Default values of the model's parameters (the plugin's and the command
#: line's). ``sigma`` and ``sigma_dd`` are RMS facet slopes; the weights are
#: dimensionless.
DEFAULTS = {
    "material": "Al",
    "sigma": 0.1,
    "ks": 1.0,
    "kdd": 0.0,
    "sigma_dd": 0.5,
    "kid": 0.0,
    "shadowing": "vgroove",
    "dd_distribution": "beckmann",
    "sampling": "mixture",
}
