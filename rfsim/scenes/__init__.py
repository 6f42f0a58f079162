"""Reusable scenes: devices of :mod:`rfsim.devices` placed in a channel of :mod:`rfsim.channels`,
ready for the air step and the protocols (an exciter-powered tag-to-tag scene, a sense-a-tag
pair near a reader, a room of reference tags, ...). The composition layer between the scenarios
(and user scripts) and the models: it may import ``rfsim.devices`` and ``rfsim.channels``; the
rest of the core never imports it.
"""
