"""The picture options' defaults, one table for Python
(:func:`~mitsuba_pbrdf.visualization.panels.overview_figure`,
:func:`~mitsuba_pbrdf.visualization.panels.save_overview_png`) and the command line
(``pbrdf render`` and ``view`` take their option defaults from it,
:func:`mitsuba_pbrdf.cli.pictures.picture_options`), so a script's first picture
looks like the command's: DoLP and DoCP scaled to the data (``"auto"``).

The ``draw_*``/``plot_*`` panel functions keep their own defaults, for figures
that set every scale themselves (the gallery's montages). Pure Python: the
command line reads it while building its parser, before NumPy is imported.
"""

#: option keyword -> default
PICTURE_DEFAULTS = {
    "dolp_limit": "auto",
    "dolp_cmap": "viridis",
    "docp_max": "auto",
    "min_dolp": 0.01,
    "stokes_scale": "shared",
    "exposure": None,
}
