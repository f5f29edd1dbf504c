"""The wavefront's event counters (RenderResult.stats): their names, and their indices in the
counter array every stage adds to."""

STATS = ("tir", "tir_absorbed", "rejected", "transmissions", "reflections", "diffuse",
         "rr_killed", "depth_limited", "caustic_splats", "lens_samples", "dielectric_samples",
         "layered_hits", "light_vertex_connections", "light_vertex_rays", "mnee_paths",
         "fresnel_splits")
(TIR_COUNT, TIR_ABSORBED_COUNT, REJECTED, TRANSMISSIONS, REFLECTIONS, DIFFUSE_HITS, RR_KILLED,
 DEPTH_LIMITED, CAUSTIC_SPLATS, LENS_SAMPLES, DIELECTRIC_SAMPLES, LAYERED_HITS,
 CONNECTIONS, VERTEX_RAYS, MNEE_PATHS, FRESNEL_SPLITS) = range(len(STATS))
