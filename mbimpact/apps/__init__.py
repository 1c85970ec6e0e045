"""The user-facing applications: the ``mbimpact`` command and what it runs.

``demo``, ``compare``, ``figures``, ``bench`` and ``run`` (scene reports). Nothing here
is imported by ``import mbimpact``: the apps (and matplotlib) load on use.
"""
