"""The architecture abstraction layer (docs/AAL.md): what crosses between the player and a vehicle.

The bottom of the vehicle side of the tree: the messages (actions out, events in, a vehicle's
declaration of what it can do) and what both ends of each transport agree on (the Zenoh key
layout and security, the MAVLink identities, modes and signing). Players' adapters
(``vehicle_adapters``) and vehicles (``vehicle``) both build on it; it imports neither.
"""
