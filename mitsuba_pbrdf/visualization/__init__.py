"""Everything a person looks at: PNG pictures of Stokes images and
matplotlib figures.

Pictures of Stokes images:

* :mod:`.panels`: the panels (intensity, DoLP, AoLP, DoCP, HSV, S1-S3) and the
  overview sheet (:func:`~.panels.save_overview_png`);
* :mod:`.composites`: pixel arrays of the HSV polarization composite and S1-S3/S0;
* :mod:`.tonemap`: linear RGB and its tone mapping;
* :mod:`.colours`: the AoLP hue wheel, automatic scales, marker colours;
* :mod:`.defaults`: the picture options' defaults, shared by Python and the command line;
* :mod:`.cube_sheet`: a Stokes cube's contact sheet and spectrum;
* :mod:`.png`: atomic PNG writing.

Figures built on them: the model's pBRDF plotted from the NumPy reference
evaluator (:mod:`.pbrdf_plots`, ``pbrdf plot``), the scene gallery that README
shows (:mod:`.gallery`, ``pbrdf gallery``), the polarization-camera figure
(:mod:`.polcam_figure`), ``pbrdf polcam``'s and ``pbrdf render``'s files
(:mod:`.polcam_files`, :mod:`.render_files`), recover-normals' recovery picture
(:mod:`.normal_recovery`) and the gallery plate's normal map
(:mod:`.normalmap_plate`).
"""
