"""dopt.view: see a plan. A browser viewer (viser) for pick-and-place trials, MPC episodes
and blow-up captures (written by ``dopt.blowup``), stills with MuJoCo's offscreen renderer.

    dopt-view PATH                    # a run folder, pack, trial or summary: serve
    dopt-view PATH --frame K --png out.png

Modules: ``episode`` (what is shown: ``Episode``, exact ``replay_controls``, the sources and
``collect``, the blow-up captures' ``load_blowup``), ``mjscene``
(a MuJoCo model in a viser scene), ``legend`` (what each marker and shade means, the floor's
scale: one legend for the browser and the still), ``player`` (the viser app, ``Viewer``),
``still`` (PNG with caption and legend), ``cli``. Importing this package loads neither
viser nor MuJoCo; serving needs the ``viz`` extra. The pick and MPC trial sources are
``planners.view`` (dopt knows no planner), found through the ``dopt.view.sources`` entry
points.
"""
