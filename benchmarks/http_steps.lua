-- wrk script of benchmarks/http_steps.py: each connection steps a plan (run wrk with as many
-- threads as connections, so that each Lua state drives one connection) with 10 random dynamic
-- obstacles on a 1024^2 map per step. Arguments after `--`: the file holding one plan id per
-- line (connection i steps plan i modulo their number), then "plan" (seq counting up from 0:
-- one connection per plan), "shared" (no seq: many connections on one plan, served one at a
-- time) or "echo" (the same bodies posted to a bare /echo endpoint).
local count = 0

function setup(thread)
   thread:set("index", count)
   count = count + 1
end

function init(args)
   local ids = {}
   for line in io.lines(args[1]) do
      table.insert(ids, line)
   end
   plan_id = ids[(index % #ids) + 1]
   mode = args[2] or "plan"
   seq = 0
   math.randomseed(index + 1)
   wrk.headers["Content-Type"] = "application/json"
end

function request()
   local cells = {}
   for i = 1, 10 do
      cells[i] = string.format("[%d,%d]", math.random(0, 1023), math.random(0, 1023))
   end
   local body
   if mode == "shared" then
      body = string.format('{"dynamic_obstacles":[%s]}', table.concat(cells, ","))
   else
      body = string.format('{"seq":%d,"dynamic_obstacles":[%s]}', seq, table.concat(cells, ","))
   end
   seq = seq + 1
   local path = "/plan/" .. plan_id .. "/step"
   if mode == "echo" then
      path = "/echo"
   end
   return wrk.format("POST", path, nil, body)
end

-- An answer that is not 2xx is a failed run: say which (status and the start of its body).
function response(status, headers, body)
   if status >= 300 then
      io.stderr:write(string.format("wrk: %d %s\n", status, string.sub(body or "", 1, 300)))
   end
end
