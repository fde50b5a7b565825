# dataset.mk: turn a tree of OBJ/PLY/OFF frame folders into HDF5 files and dtx
# results, redoing only what changed.
#
#   make -f scripts/dataset.mk -j2 DATA=dir OUT=outdir [DTX=path/to/dtx] [NP=4]
#
# Input tree (names of sequences and targets: letters, digits, '_', '.', '-';
# no blanks in the DATA and OUT paths):
#
#   DATA/source/rest.obj                  source rest mesh (or rest.ply / rest.off)
#   DATA/sequences/SEQ/*.obj|*.ply|*.off  one folder of frames per sequence, in
#                                         natural name order (frame-2 before frame-10),
#                                         all with the rest mesh's faces
#   DATA/targets/TGT/mesh.obj             a target mesh (or mesh.ply / mesh.off)
#   DATA/targets/TGT/markers.csv          source_vertex,target_vertex[,label] per line
#   DATA/targets/TGT/index-base           optional: "0" or "1", the CSV's index base;
#                                         without it MARKER_BASE (default 0) applies
#
# Output tree (every file is written under a temporary name and moved into place,
# so an interrupted or failed step never leaves a file that looks up to date):
#
#   OUT/sequences/SEQ.h5       /meshes/source + /sequences/SEQ      (dtx import)
#   OUT/targets/TGT.h5         /meshes/source + /meshes/TGT + /markers/TGT
#   OUT/jobs/TGT/SEQ.json      the dtx job of one (target, sequence) pair
#   OUT/results/TGT/SEQ.h5     /results/TGT/SEQ                     (dtx run)
#   OUT/results/TGT/SEQ.h5.summary.json    (and SEQ.h5.partial while it runs)
#   OUT/correspondences/KEY.h5 the correspondence store: one file per target
#                              correspondence, shared by all the target's jobs
#   OUT/.corr/TGT              stamp: TGT's correspondence is in the store
#   OUT/.vars/*                the values of the variables below that change outputs
#
# One result per (target, sequence) pair, so that a changed frame reruns only the
# pairs of its sequence and changed markers or a changed target mesh rerun only the
# pairs of that target.  Each target's correspondence is computed once, before its
# pairs (dtx run --correspond-only into the store OUT/correspondences, keyed by a
# hash of the meshes, markers and parameters); every pair's job names the store
# and takes it from there, so N sequences onto a target cost one correspondence.
#
# Variables (those marked * are recorded in OUT/.vars: changing them redoes the
# steps they affect; the others never do):
#   DATA          the input tree (required)
#   OUT           the output tree (default: out)
#   DTX           the dtx binary (default: dtx on PATH)
#   SEQ_DTYPE   * float32 | float64: how imported frames are stored (default float32)
#   MARKER_BASE * 0 | 1: index base of markers.csv files without an index-base file
#   OUT_DTYPE   * float32 | float64: result positions (default float32)
#   BLOCK_FRAMES* frames per read/solve/write block (default: dtx's)
#   TRANSLATION * fixed | follow (default: dtx's, fixed)
#   SP04        * JSON object of sp04 parameters, e.g. SP04='{"w_identity": 0.3}'
#   NP            MPI ranks per dtx run: runs "$(MPIRUN) $(NPFLAG) $(NP) dtx run ..."
#                 (default: none, a plain MPI singleton run)
#   MPIRUN        launcher used with NP (default mpirun; srun works with NPFLAG=-n)
#   THREADS       OMP_NUM_THREADS for each dtx run (default: the environment's).
#                 Keep make's -j x NP x THREADS at most the number of cores.
#   RESUME        --resume (default): a pair whose run was interrupted continues
#                 from the frames already written; RESUME= starts it over
#   RUNFLAGS      extra "dtx run" flags, e.g. --quiet
#
# Targets: all (default), imports, jobs, list, clean, help.

SHELL := /bin/bash
.SHELLFLAGS := -euo pipefail -c
.ONESHELL:
.DELETE_ON_ERROR:
.SUFFIXES:
MAKEFLAGS += --no-builtin-rules --no-builtin-variables

OUT ?= out
DTX ?= dtx
SEQ_DTYPE ?= float32
MARKER_BASE ?= 0
OUT_DTYPE ?= float32
BLOCK_FRAMES ?=
TRANSLATION ?=
SP04 ?=
NP ?=
MPIRUN ?= mpirun
NPFLAG ?= -np
THREADS ?=
RESUME ?= --resume
RUNFLAGS ?=

only_cleaning := $(if $(MAKECMDGOALS),$(if $(filter-out clean help,$(MAKECMDGOALS)),,1))

# --------------------------------------------------------------------------
# Discovery and checks of the input tree (at parse time, so that a broken tree
# fails before any work starts, with the file that is missing).
# --------------------------------------------------------------------------
mesh_exts := obj ply off OBJ PLY OFF
first_mesh = $(firstword $(foreach e,$(mesh_exts),$(wildcard $1.$e)))
frames_of = $(sort $(foreach e,$(mesh_exts),$(wildcard $(DATA)/sequences/$1/*.$e)))
target_mesh = $(call first_mesh,$(DATA)/targets/$1/mesh)
dirs_in = $(sort $(patsubst %/,%,$(notdir $(patsubst %/,%,$(wildcard $1/*/)))))
# pair_target / pair_seq: "TGT/SEQ" -> TGT, SEQ.
pair_target = $(patsubst %/,%,$(dir $1))
pair_seq = $(notdir $1)

ifndef only_cleaning
ifeq ($(strip $(DATA)),)
$(error DATA is not set: make -f scripts/dataset.mk DATA=dir OUT=outdir (see the header of this file))
endif
ifeq ($(wildcard $(DATA)/.),)
$(error DATA=$(DATA): no such directory)
endif
endif

SOURCE_REST := $(call first_mesh,$(DATA)/source/rest)
SEQS := $(call dirs_in,$(DATA)/sequences)
TGTS := $(call dirs_in,$(DATA)/targets)
PAIRS := $(foreach t,$(TGTS),$(addprefix $t/,$(SEQS)))
RESULTS := $(PAIRS:%=$(OUT)/results/%.h5)
# The job each target's correspondence is computed with (any sequence would do:
# they share the source rest mesh).
FIRST_SEQ := $(firstword $(SEQS))
CORR_STAMPS := $(TGTS:%=$(OUT)/.corr/%)
JOBS := $(PAIRS:%=$(OUT)/jobs/%.json)
IMPORTS := $(SEQS:%=$(OUT)/sequences/%.h5) $(TGTS:%=$(OUT)/targets/%.h5)

ifndef only_cleaning
ifeq ($(SOURCE_REST),)
$(error $(DATA)/source/rest.obj (or .ply, .off): missing; it is the source rest mesh)
endif
ifeq ($(SEQS),)
$(error $(DATA)/sequences/: no sequence folders (one folder of frames per sequence))
endif
ifeq ($(TGTS),)
$(error $(DATA)/targets/: no target folders (each with mesh.obj and markers.csv))
endif
bad_names := $(shell printf '%s\n' $(SEQS) $(TGTS) | grep -v '^[A-Za-z0-9_.-]*$$' || true)
ifneq ($(bad_names),)
$(error names may only use letters, digits, '_', '.' and '-': $(bad_names))
endif
ifneq ($(filter source,$(TGTS)),)
$(error $(DATA)/targets/source: the name "source" is taken by the source mesh; rename the folder)
endif
$(foreach s,$(SEQS),$(if $(call frames_of,$s),,$(error $(DATA)/sequences/$s/: no .obj, .ply or .off frames)))
$(foreach t,$(TGTS),$(if $(call target_mesh,$t),,$(error $(DATA)/targets/$t/mesh.obj (or .ply, .off): missing)))
$(foreach t,$(TGTS),$(if $(wildcard $(DATA)/targets/$t/markers.csv),,$(error $(DATA)/targets/$t/markers.csv: missing)))
$(foreach v,SEQ_DTYPE OUT_DTYPE,$(if $(filter float32 float64,$($v)),,$(error $v=$($v): must be float32 or float64)))
$(if $(filter 0 1,$(MARKER_BASE)),,$(error MARKER_BASE=$(MARKER_BASE): must be 0 or 1))
# The outputs must not land among the inputs (they would be taken for frames).
$(if $(filter $(abspath $(DATA)),$(abspath $(OUT))),$(error OUT=$(OUT) is DATA itself; choose another OUT))
$(foreach d,source sequences targets,$(if $(filter $(abspath $(DATA)/$d) $(abspath $(DATA)/$d)/%,$(abspath $(OUT))),\
    $(error OUT=$(OUT) is inside $(DATA)/$d; choose another OUT)))
endif

# --------------------------------------------------------------------------
# Variable stamps: OUT/.vars/NAME holds the values that affect a step and is
# rewritten (so becomes newer) only when they change.  Done at parse time with
# $(file), so an unchanged tree stays "up to date" for make -q.
# --------------------------------------------------------------------------
vars_import := seq_dtype=$(SEQ_DTYPE)
vars_markers := marker_base=$(MARKER_BASE)
vars_job := out_dtype=$(OUT_DTYPE) block_frames=$(BLOCK_FRAMES) translation=$(TRANSLATION) sp04=$(SP04)
define stamp
ifndef only_cleaning
ifneq ($$(file <$(OUT)/.vars/$1),$$(vars_$1))
$$(shell mkdir -p '$(OUT)/.vars')
$$(file >$(OUT)/.vars/$1,$$(vars_$1))
endif
endif
endef
$(foreach v,import markers job,$(eval $(call stamp,$v)))

# The job text of target $1 and sequence $2.  Every line starts with '|',
# removed when the file is written: .ONESHELL strips the leading blanks of
# recipe lines, and with them the indentation.
, := ,
define job_json
|{
|  "dtx_job": 1,
|  "method": "sp04",
|  "source": {"file": "../../sequences/$2.h5", "mesh": "/meshes/source",
|             "sequences": ["/sequences/$2"]},
|  "targets": [{"name": "$1", "file": "../../targets/$1.h5", "mesh": "/meshes/$1",$(if $(TRANSLATION),
|               "translation": "$(TRANSLATION)"$(,))
|               "markers": {"file": "../../targets/$1.h5", "path": "/markers/$1"}}],
|  "correspondence_store": "../../correspondences",
|  "output": {"file": "../../results/$1/$2.h5", "dtype": "$(OUT_DTYPE)"$(if $(BLOCK_FRAMES),$(,) "block_frames": $(BLOCK_FRAMES))}$(if $(SP04),$(,)
|  "sp04": $(SP04))
|}
endef
# shq: $1 quoted for the shell.
shq = '$(subst ','\'',$1)'

# --------------------------------------------------------------------------
# Rules.
# --------------------------------------------------------------------------
.PHONY: all imports jobs list clean help
all: $(CORR_STAMPS) $(RESULTS)
imports: $(IMPORTS)
jobs: $(JOBS)

list:
	@echo "source:    $(SOURCE_REST)"
	echo "sequences: $(foreach s,$(SEQS),$s ($(words $(call frames_of,$s)) frames))"
	echo "targets:   $(TGTS)"
	echo "results:   $(words $(RESULTS)) in $(OUT)/results"

help:
	@sed -n '1,/^$$/s/^# \{0,1\}//p' $(firstword $(MAKEFILE_LIST))

clean:
	@rm -rf '$(OUT)/sequences' '$(OUT)/targets' '$(OUT)/jobs' '$(OUT)/results' '$(OUT)/.vars' \
	    '$(OUT)/correspondences' '$(OUT)/.corr'

.SECONDEXPANSION:

# A sequence file: the source rest mesh and the frames.  The folder itself is a
# prerequisite so that an added, removed or renamed frame (which changes the
# folder but no remaining file) redoes the import.
$(OUT)/sequences/%.h5: $(SOURCE_REST) $(DATA)/sequences/% $$(call frames_of,$$*) \
                       $(OUT)/.vars/import
	@mkdir -p '$(@D)'
	tmp='$@.tmp'
	trap 'rm -f "$$tmp"' EXIT
	rm -f "$$tmp"
	'$(DTX)' import mesh '$(SOURCE_REST)' -o "$$tmp" --name source
	'$(DTX)' import sequence '$(DATA)/sequences/$*' -o "$$tmp" --name '$*' \
	    --mesh /meshes/source --dtype $(SEQ_DTYPE)
	mv -f "$$tmp" '$@'

# A target file: the source rest mesh (so that the marker indices are checked
# against both meshes at import), the target mesh and its markers.
$(OUT)/targets/%.h5: $(SOURCE_REST) $$(call target_mesh,$$*) $(DATA)/targets/%/markers.csv \
                     $(DATA)/targets/% $$(wildcard $(DATA)/targets/$$*/index-base) \
                     $(OUT)/.vars/markers
	@mkdir -p '$(@D)'
	tmp='$@.tmp'
	trap 'rm -f "$$tmp"' EXIT
	base=$(MARKER_BASE)
	if [[ -f '$(DATA)/targets/$*/index-base' ]]; then
	    read -r base < '$(DATA)/targets/$*/index-base' || true
	    if [[ $$base != [01] ]]; then
	        echo "$(DATA)/targets/$*/index-base: must hold 0 or 1, not '$$base'" >&2
	        exit 1
	    fi
	fi
	rm -f "$$tmp"
	'$(DTX)' import mesh '$(SOURCE_REST)' -o "$$tmp" --name source
	'$(DTX)' import mesh '$(call target_mesh,$*)' -o "$$tmp" --name '$*'
	'$(DTX)' import markers '$(DATA)/targets/$*/markers.csv' --index-base "$$base" \
	    -o "$$tmp" --name '$*' --source /meshes/source --target '/meshes/$*'
	mv -f "$$tmp" '$@'

# The job of one pair; the stem is TGT/SEQ.  Paths are relative to the job file.
$(OUT)/jobs/%.json: $(OUT)/.vars/job
	@mkdir -p '$(@D)'
	echo "job $@"
	tmp='$@.tmp'
	trap 'rm -f "$$tmp"' EXIT
	printf '%s\n' $(call shq,$(call job_json,$(call pair_target,$*),$(call pair_seq,$*))) \
	    | sed 's/^|//' > "$$tmp"
	mv -f "$$tmp" '$@'

# A target's correspondence, computed once into the store before any of its
# pairs run (a pair's run then takes it from there).  The stamp is redone when
# the source rest mesh, the target file or the job text (the sp04 parameters)
# changes, not when the frames of the sequence whose job it uses do; a
# correspondence already in the store under the same key is not computed
# again.  The pairs wait for it (order-only: a redone stamp alone reruns no
# pair; whatever changes a pair's correspondence changes its job or target).
$(OUT)/.corr/%: $(OUT)/jobs/%/$(FIRST_SEQ).json $(SOURCE_REST) $(OUT)/targets/%.h5 \
                | $(OUT)/sequences/$(FIRST_SEQ).h5
	@mkdir -p '$(@D)'
	echo "dtx run --correspond-only $<"
	$(if $(THREADS),OMP_NUM_THREADS=$(THREADS)) OPENBLAS_NUM_THREADS=1 \
	    $(if $(NP),$(MPIRUN) $(NPFLAG) $(NP)) '$(DTX)' run --correspond-only $(RUNFLAGS) '$<'
	touch '$@'

# The result of one pair.  dtx run itself writes OUTPUT.partial and renames it
# into place at the end; with --resume it continues the partial file of an
# interrupted run, or does nothing when the output already matches the job and
# its inputs (then the touch tells make it is up to date).
$(OUT)/results/%.h5: $(OUT)/jobs/%.json $(OUT)/sequences/$$(call pair_seq,$$*).h5 \
                     $(OUT)/targets/$$(call pair_target,$$*).h5 \
                     | $(OUT)/.corr/$$(call pair_target,$$*)
	@mkdir -p '$(@D)'
	echo "dtx run $<"
	$(if $(THREADS),OMP_NUM_THREADS=$(THREADS)) OPENBLAS_NUM_THREADS=1 \
	    $(if $(NP),$(MPIRUN) $(NPFLAG) $(NP)) '$(DTX)' run $(RESUME) $(RUNFLAGS) '$<'
	touch '$@'
