"""Reusable scenes: devices of :mod:`rfsim.devices` placed in a channel of :mod:`rfsim.channels`,
ready for the air step and the protocols. The composition layer between the scenarios (and user
scripts) and the models: it may import ``rfsim.devices`` and ``rfsim.channels``; the rest of the
core never imports it.

Modules: :mod:`~rfsim.scenes.links` (drawn and batched links), :mod:`~rfsim.scenes.exciter`
(exciter-powered tag-to-tag scenes), :mod:`~rfsim.scenes.reference_tags` (reference-tag slots at
sample level), :mod:`~rfsim.scenes.aisle` (the mobile tag's aisle and motion),
:mod:`~rfsim.scenes.tag_listening` (a reader, a tag and sense-a-tags listening),
:mod:`~rfsim.scenes.st_detection` (one Query round with a sense-a-tag listening, batched),
:mod:`~rfsim.scenes.reader_queries` (queries of one trial over held links),
:mod:`~rfsim.scenes.himr_air` (HIMR tag and pylons at sample level),
:mod:`~rfsim.scenes.rss_rooms` and :mod:`~rfsim.scenes.active_beacons` (active-RFID rooms and
beacons), :mod:`~rfsim.scenes.landmark_room` (a floor of landmark tags under the reader's
panels, the sense-a-tag's paths), :mod:`~rfsim.scenes.landmark_listening` (a sense-a-tag listening
to the landmarks' Gen2 inventory at sample level) and :mod:`~rfsim.scenes.landmark_tracks` (its
tracks, surrogate or listened, the trackers on them and their tables).
"""
