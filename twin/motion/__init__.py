"""Measured vessel motion: a motion reference unit's (MRU) log or live stream as the twin's
input, below the simulation layer (it reads the vessel layer's frames, never sim or web).

- `series`: `MotionSeries`, six degrees of freedom against time, with what was skipped;
- `sensor`: where the MRU sits on the hull and its sign conventions (`Sensor`);
- `mount`: the motion moved from the sensor to a mechanism's mount (rigid body);
- `logs`: CSV/Parquet logs; `nmea` and `tss1`: the sentences MRUs send; `stream`: a live byte
  stream parsed as it comes; `replay`: a log sent back out as sentences;
- `estimate`: the sea state from the motion (the wave buoy analogy).
"""
