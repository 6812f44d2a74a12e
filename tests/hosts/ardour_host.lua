-- Headless Ardour 7 host test for the Struck VST3 plugins.
--
-- Run through tests/hosts/ardour_host.sh, which prepares the environment
-- (private VST3 folder via VST3_PATH, pre-scanned VST3 cache, private
-- XDG_CONFIG_HOME holding an export preset and two small Lua DSP test
-- generators) and analyses the exported WAV files afterwards.
--
--   ardour7-lua ardour_host.lua WORKDIR PHASE [TRACK]
--
-- PHASE is one of
--   setup        create the session, check discovery, build the tracks, save
--   render TRACK load the session, mute all other tracks, export 2 s of the
--                master bus to WORKDIR/out/<TRACK>.wav (32-bit float, no
--                dither, 48 kHz)
--   state-set    load, change one parameter of each plugin, save
--   state-check  load, compare the parameters with the saved values
--
-- Each phase is a separate ardour7-lua process because Ardour 7.3's
-- SimpleExport corrupts the heap now and then when used from ardour7-lua
-- (reproducible without any plugin); the driver retries a crashed phase.
--
-- Every check is reported as a line "RESULT|<name>|PASS|FAIL|<detail>" on
-- stdout and appended to WORKDIR/results-<phase>.txt (so that results survive
-- a crash), the last line of a completed phase is "DONE|<phase>".

local WORK  = arg[1]
local PHASE = arg[2]
local TRACK = arg[3]
local LABEL = arg[4] or TRACK
assert (WORK and PHASE, "usage: ardour7-lua ardour_host.lua WORKDIR PHASE [TRACK]")

local SR       = 48000
local LEN      = 2 * SR                 -- 2 s exports
local SNAME    = "struck_host"
local SDIR     = WORK .. "/session"
local OUTDIR   = WORK .. "/out"
local PRESET   = "5e8a3f52-6b1d-4c1e-9a77-3d2f0c5b7e00" -- written by ardour_host.sh
local INST     = "Struck"
local EFFECT   = "Struck Resonator"
local NOTE_GEN = "Struck Test Note"     -- Lua DSP scripts written by ardour_host.sh
local CLICK_GEN = "Struck Test Click"

local results = io.open (WORK .. "/results-" .. PHASE .. (LABEL and ("-" .. LABEL) or "") .. ".txt", "w")

local function result (name, ok, detail)
	local line = string.format ("RESULT|%s|%s|%s", name, ok and "PASS" or "FAIL", tostring (detail or ""))
	print (line)
	results:write (line .. "\n")
	results:flush ()
end

local function info (k, v)
	local line = string.format ("INFO|%s|%s", k, tostring (v))
	print (line)
	results:write (line .. "\n")
	results:flush ()
end

local function now () return ARDOUR.LuaAPI.monotonic_time () / 1e6 end

local function done ()
	local line = "DONE|" .. PHASE .. (LABEL and ("|" .. LABEL) or "")
	print (line)
	results:write (line .. "\n")
	results:close ()
end

---------------------------------------------------------------------------
-- helpers
---------------------------------------------------------------------------
local function processors (route)
	local names = {}
	local i = 0
	while true do
		local p = route:nth_processor (i)
		if p:isnil () then break end
		names[#names + 1] = p:display_name ()
		i = i + 1
	end
	return table.concat (names, " > ")
end

local function find_plugin (route, name)
	local i = 0
	while true do
		local p = route:nth_plugin (i)
		if p:isnil () then return nil end
		if p:display_name () == name or p:name () == name then return p end
		i = i + 1
	end
end

local function add_proc (route, proc, idx)
	-- add_processor_by_index returns 0 on success
	return route:add_processor_by_index (proc, idx, nil, true) == 0
end

local function audio_track (name)
	local tl = Session:new_audio_track (2, 2, nil, 1, name, ARDOUR.PresentationInfo.max_order, ARDOUR.TrackMode.Normal, true)
	return tl:front ()
end

local function all_tracks ()
	local t = {}
	for r in Session:get_routes ():iter () do
		if not r:to_track ():isnil () then t[r:name ()] = r end
	end
	return t
end

local function save ()
	return Session:save_state ("", false, false, false, false, false)
end

local function open_session ()
	AudioEngine:set_backend ("None (Dummy)", "", "")
	local t0 = now ()
	local s = load_session (SDIR, SNAME)
	if not s then
		result (PHASE .. ": load session", false, "load_session returned nil")
		return false
	end
	info ("session loaded", string.format ("%.2fs", now () - t0))
	return true
end

-- plugin parameter chosen for the state round trip: the preferred label if
-- present, else the first continuous input parameter
local function pick_param (proc, prefer)
	local pl = proc:to_insert ():plugin (0)
	local chosen
	for j = 0, pl:parameter_count () - 1 do
		if pl:parameter_is_input (j) then
			local _, pd = pl:get_parameter_descriptor (j, ARDOUR.ParameterDescriptor ())
			local d = pd[2]
			local label = pl:parameter_label (j)
			local plain = not d.toggled and not d.integer_step and not d.enumeration and d.upper > d.lower
			if plain and (label == prefer or not chosen) then
				chosen = { idx = j, label = label, lower = d.lower, upper = d.upper }
				if label == prefer then break end
			end
		end
	end
	return chosen
end

local STATE_PARAMS = { { track = "Resonator", plugin = EFFECT, prefer = "Size" },
                       { track = "Inst",      plugin = INST,   prefer = "Size" } }
local STATE_FILE = WORK .. "/state-expect.txt"

---------------------------------------------------------------------------
-- phase: setup
---------------------------------------------------------------------------
local function phase_setup ()
	AudioEngine:set_backend ("None (Dummy)", "", "")
	local bename = AudioEngine:current_backend_name ()
	result ("engine: dummy backend", bename == "Dummy", "backend=" .. tostring (bename))

	local t0 = now ()
	if not create_session (SDIR, SNAME, SR) then
		result ("session: create", false, "create_session returned nil")
		return
	end
	result ("session: create @48k", Session:nominal_sample_rate () == SR,
		string.format ("sr=%d, %.2fs", Session:nominal_sample_rate (), now () - t0))

	-- discovery (Ardour's plugin index, built from the VST3 scanner cache)
	local found = {}
	local n_plugins = 0
	for p in ARDOUR.LuaAPI.list_plugins ():iter () do
		n_plugins = n_plugins + 1
		if p.type == ARDOUR.PluginType.VST3 then
			found[p.name] = p.unique_id
			info ("vst3 plugin", p.name .. " uid=" .. p.unique_id .. " creator=" .. p.creator .. " category=" .. p.category)
		end
	end
	info ("plugins indexed", n_plugins)
	for _, name in ipairs ({ INST, EFFECT }) do
		result ("discover: VST3 '" .. name .. "'", found[name] ~= nil, found[name] and ("uid=" .. found[name]) or "not in Ardour's plugin list")
	end

	-- 1. reference: click generator only (validates the test input itself)
	local t = audio_track ("ClickRef")
	local gen = ARDOUR.LuaAPI.new_luaproc (Session, CLICK_GEN)
	result ("setup: click generator track", not gen:isnil () and add_proc (t, gen, 0), processors (t))

	-- 2. effect: click -> Struck Resonator
	t = audio_track ("Resonator")
	gen = ARDOUR.LuaAPI.new_luaproc (Session, CLICK_GEN)
	local fx = ARDOUR.LuaAPI.new_plugin (Session, EFFECT, ARDOUR.PluginType.VST3, "")
	local ok = not gen:isnil () and not fx:isnil () and add_proc (t, gen, 0) and add_proc (t, fx, 1)
	result ("insert: '" .. EFFECT .. "' after click", ok, processors (t))
	if not fx:isnil () then
		info ("effect io", string.format ("in=%d out=%d latency=%d params=%d",
			fx:to_insert ():input_streams ():n_audio (), fx:to_insert ():output_streams ():n_audio (),
			fx:signal_latency (), fx:to_insert ():plugin (0):parameter_count ()))
	end

	-- 3. effect on silence: empty audio track -> Struck Resonator
	t = audio_track ("ResSilence")
	local fx2 = ARDOUR.LuaAPI.new_plugin (Session, EFFECT, ARDOUR.PluginType.VST3, "")
	result ("insert: '" .. EFFECT .. "' on silent track", not fx2:isnil () and add_proc (t, fx2, 0), processors (t))

	-- 4. instrument: MIDI track with Struck, fed by the note generator
	local pi = ARDOUR.LuaAPI.new_plugin_info (INST, ARDOUR.PluginType.VST3)
	if pi:isnil () then
		result ("insert: '" .. INST .. "' on MIDI track", false, "new_plugin_info failed")
	else
		local tl = Session:new_midi_track (
			ARDOUR.ChanCount (ARDOUR.DataType ("midi"), 1), ARDOUR.ChanCount (ARDOUR.DataType ("audio"), 2),
			false, pi, nil, nil, 1, "Inst", ARDOUR.PresentationInfo.max_order, ARDOUR.TrackMode.Normal, true)
		t = tl:front ()
		local ngen = ARDOUR.LuaAPI.new_luaproc (Session, NOTE_GEN)
		local ip = find_plugin (t, INST)
		result ("insert: '" .. INST .. "' on MIDI track (+note generator)",
			ip ~= nil and not ngen:isnil () and add_proc (t, ngen, 0), processors (t))
		if ip then
			info ("instrument io", string.format ("midi_in=%d audio_out=%d latency=%d",
				ip:to_insert ():input_streams ():n_midi (), ip:to_insert ():output_streams ():n_audio (), ip:signal_latency ()))
		end
	end
	local rc = save ()
	result ("session: save", rc == 0, "save_state rc=" .. tostring (rc))
	close_session ()
end

---------------------------------------------------------------------------
-- phase: render TRACK (alone through the master bus)
---------------------------------------------------------------------------
local function phase_render (track_name, file_name)
	if not open_session () then return end
	local tracks = all_tracks ()
	if not tracks[track_name] then
		result ("render: " .. file_name, false, "no track " .. track_name .. " in session")
		close_session ()
		return
	end
	info (track_name .. " processors", processors (tracks[track_name]))
	for n, r in pairs (tracks) do
		r:mute_control ():set_value (n == track_name and 0 or 1, PBD.GroupControlDisposition.NoGroup)
	end
	sleep (0.2)
	local e = Session:simple_export ()
	if not e:set_preset (PRESET) then
		result ("render: " .. file_name, false, "export preset " .. PRESET .. " not found")
	else
		e:set_folder (OUTDIR)
		e:set_name (file_name)
		e:set_range (0, LEN)
		local t0 = now ()
		local ok = e:run_export ()
		result ("render: " .. file_name, ok, string.format ("track %s -> out/%s.wav, %.2fs", track_name, file_name, now () - t0))
	end
	close_session ()
end

---------------------------------------------------------------------------
-- phase: state-set / state-check
---------------------------------------------------------------------------
local function phase_state_set ()
	if not open_session () then return end
	local tracks = all_tracks ()
	local f = io.open (STATE_FILE, "w")
	for _, sp in ipairs (STATE_PARAMS) do
		local p = tracks[sp.track] and find_plugin (tracks[sp.track], sp.plugin)
		local c = p and pick_param (p, sp.prefer)
		if not c then
			result ("state: set a parameter on '" .. sp.plugin .. "'", false, p and "no continuous input parameter" or "plugin not found")
		else
			local before = ARDOUR.LuaAPI.get_processor_param (p, c.idx)
			local v = c.lower + 0.37 * (c.upper - c.lower)
			local set_ok = ARDOUR.LuaAPI.set_processor_param (p, c.idx, v)
			sleep (0.1)
			local after = ARDOUR.LuaAPI.get_processor_param (p, c.idx)
			f:write (string.format ("%s\t%s\t%d\t%s\t%.17g\t%.17g\n", sp.track, sp.plugin, c.idx, c.label, after, c.upper - c.lower))
			result ("state: set '" .. sp.plugin .. "' " .. c.label, set_ok and math.abs (after - v) <= 1e-4 * (c.upper - c.lower),
				string.format ("param #%d %.6g -> %.6g (requested %.6g)", c.idx, before, after, v))
		end
	end
	f:close ()
	local rc = save ()
	result ("state: save session", rc == 0, "save_state rc=" .. tostring (rc))
	close_session ()
end

local function phase_state_check ()
	if not open_session () then return end
	local tracks = all_tracks ()
	local f = io.open (STATE_FILE, "r")
	if not f then
		result ("state: expected values", false, "no " .. STATE_FILE)
	else
		for line in f:lines () do
			local track, plugin, idx, label, value, range = line:match ("^(.-)\t(.-)\t(%d+)\t(.-)\t(%S+)\t(%S+)$")
			idx, value, range = tonumber (idx), tonumber (value), tonumber (range)
			local p = tracks[track] and find_plugin (tracks[track], plugin)
			if not p then
				result ("state: '" .. plugin .. "' " .. label .. " survives save/reload", false, "plugin missing after reload on track " .. track)
			else
				local v = ARDOUR.LuaAPI.get_processor_param (p, idx)
				result ("state: '" .. plugin .. "' " .. label .. " survives save/reload",
					math.abs (v - value) <= 1e-4 * range, string.format ("saved %.6g, reloaded %.6g", value, v))
			end
		end
		f:close ()
	end
	close_session ()
end

---------------------------------------------------------------------------
if PHASE == "setup" then
	phase_setup ()
elseif PHASE == "render" then
	phase_render (TRACK, LABEL)
elseif PHASE == "state-set" then
	phase_state_set ()
elseif PHASE == "state-check" then
	phase_state_check ()
else
	result ("phase", false, "unknown phase " .. tostring (PHASE))
end
done ()
