"""The Colin27 protocol shared by the scripts beside this file: where Debian's
mricron-data keeps the scan and its AAL labels, and the eight structures
the BENCHMARKS tables report (AAL label, name), right and left."""
MRI = "/usr/share/mricron/templates"
STRUCTURES = [(73, "putamen L"), (74, "putamen R"), (77, "thalamus L"), (78, "thalamus R"),
              (71, "caudate L"), (72, "caudate R"), (37, "hippocampus L"), (38, "hippocampus R")]
