"""UAS geographical zones (EUROCAE ED-269 JSON, ED-318 GeoJSON): read, decided, selected.

:mod:`.model` holds one zone as published (volumes, time periods, restriction); :mod:`.ed269`
and :mod:`.ed318` read the two formats into it; :mod:`.applicability` decides whether a zone
applies to a flight (height band, time window, restriction, authorisations); :mod:`.selection`
picks the zones within reach of a site from a country-scale file with a spatial index.
"""
