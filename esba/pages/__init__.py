"""The docs pages: each renders what a computation or a benchmark returned, as Markdown and figures.

May import :mod:`esba.bench` and everything below it.
"""
