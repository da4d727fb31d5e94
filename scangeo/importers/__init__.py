"""What sensors and other tools write, as scangeo projects: drone pushbroom lines (``.lcf``, ``.times``, an ENVI
cube: :mod:`scangeo.importers.lcf`) and PARGE status files of HySpex lines (:mod:`scangeo.importers.parge`), each
read and checked, its conventions found from the data, written atomically by :mod:`scangeo.importers.writer`
and recorded in ``import.json`` (:mod:`scangeo.importers.record`; docs/architecture.md, "Importers")."""
