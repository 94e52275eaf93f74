"""The report engine: result files -> docs/RESULTS.md, a page per paper, README's map.

Modules: ``base`` (``Result``, ``load_results``, the Markdown helpers), ``engine``
(``generate``: the pages from the registered experiments' hooks, ``dopt.lab.experiment``),
``cli`` (``python experiments/report.py [--check]``, ``dopt-report``), ``map`` (README's map,
``MapRow``), ``claims`` (``Claim``, ``Finding``, ``share``), ``pages`` (a paper's page,
``Page``), ``trials`` (the committed trials behind a summary), ``stale`` (findings and their
notes), ``stats`` (the tests behind the sentences), ``resummarize`` (summaries rebuilt from
their trials). It never names a kind of result file: the paper slices' experiments
(``planners/<slice>/experiments/registry.py``) hold what is particular to a figure or table.
"""
