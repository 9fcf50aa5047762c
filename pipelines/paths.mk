# Paths go into targets, prerequisites and shell lines unquoted: make
# splits a name at a space, and the shell reads quotes, `;`, `|` and the
# like. A path with one of them is refused here, on one line, before any
# work (docs/GUIDE.md, "Your own mesh").
PATH_VARS := MESH OUT NAME BIN LIGHTS CAMERA MATERIAL TEXTURE DIRECT FRAMES REST REST_CLOUD REST_MESH
sq := '
dq := "
lp := (
rp := )
UNSAFE := $(sq) $(dq) ` ; & | < > $(lp) $(rp) \ !
unsafe = $(or $(filter-out 0 1,$(words $(1))),$(strip $(foreach c,$(UNSAFE),$(findstring $(c),$(1)))))
$(foreach v,$(PATH_VARS),$(if $(call unsafe,$($(v))),$(error $(v)=$($(v)): a path with a space or one of $(UNSAFE) cannot go through make's rules; rename it, or link to it from a path without them)))
