"""Staged runs over the layers below: :mod:`scangeo.pipeline.demo` simulates a block, compares the
strategies, rectifies and reports in one call."""
