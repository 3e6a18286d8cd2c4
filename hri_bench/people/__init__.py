"""People in the loop: recording sessions, playing in the terminal, serving a web page.

==============  ====================================================================
module          contents
==============  ====================================================================
``recording``   the human seat's recorder, and scripted humans' sessions recorded
``play``        ``hri-bench play``: you are the human, in the terminal
``serve``       ``hri-bench serve``: a person plays the human in a browser
==============  ====================================================================

It imports only the layers below :mod:`hri_bench.suite` (``lint-imports``).
"""
