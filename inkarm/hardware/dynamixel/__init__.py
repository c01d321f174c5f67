"""Dynamixel X-series servo arms on dynamixel-sdk (Protocol 2.0), and their emulator.

``tables`` (control tables as data), ``config`` (a profile's ``[backends.dynamixel]``),
``bus`` (the SDK side), ``plant`` (:class:`DynamixelPlant`), ``calibration``; the emulator:
``protocol``, ``memory``, ``instructions``, ``physics``, ``emulator``.
"""
