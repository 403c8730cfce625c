"""The docs pages: each a :class:`~esba.pages.page.Page` that asks a computation or a benchmark for
its data (compute), renders it as Markdown and figures (render), writes it and checks the committed
page against a fresh computation, times aside (:mod:`.page`). :mod:`.registry` lists them all, for
``esba docs --check`` / ``--write`` and for each page's own command; one module per page
(:mod:`.derivations`, :mod:`.validation`, :mod:`.design`, :mod:`.paths`, :mod:`.experiments`,
:mod:`.accuracy`, :mod:`.performance`, :mod:`.scaling`), :mod:`.sections` for a page made of
sections. A page renders only: what it shows is computed below it.

May import :mod:`esba.bench` and everything below it (and :mod:`derive`, whose audit page it wraps).
"""
