"""Figures: the model's pBRDF plotted from the NumPy reference evaluator
(:mod:`.pbrdf_plots`, ``pbrdf plot``) and the scene gallery that README shows
(:mod:`.gallery`, ``pbrdf gallery``)."""
