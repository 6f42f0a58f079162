"""Reference estimators: the filters and locators the source documents used.

Small, vectorised (over particles and trials) implementations, each with its
equation and source in the docstring, cross-checked in the tests against
well-kept libraries (filterpy for the Kalman family) or brute-force references.
They are references for validating datasets, not a tracking library.

The public names are listed one per line so that independent additions merge.
"""

__all__ = [
]
